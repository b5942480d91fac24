#pragma once
// Internal: the root attributes every model file carries about what produced it (program
// version, mesh, material, damping, integrator, step), shared by the point model
// (impulse_response.cc) and the virtual-DOF model (virtual_dof.cc).
#include <irdm_common/h5.h>
#include <reference_fem/mesh.h>
#include <reference_fem/scene.h>

#include "integrator.h"

#include <string>

namespace irdm::fem
{
  inline void
  write_provenance(h5::Writer &f, const Scene &scene, const IntegratorCoefficients &coef)
  {
    std::string fixed;
    for (const auto &s : scene.fixed_surfaces)
      fixed += (fixed.empty() ? "" : ",") + s;
    f.attribute("/", "irdm_version", std::string(IRDM_VERSION));
    f.attribute("/", "time_step_s", scene.time_step);
    f.attribute("/", "integrator",
                std::string(scene.integrator == Integrator::newmark ? "newmark" : "generalized_alpha"));
    f.attribute("/", "rho_inf", scene.rho_inf);
    f.attribute("/", "alpha_m", coef.alpha_m);
    f.attribute("/", "alpha_f", coef.alpha_f);
    f.attribute("/", "gamma", coef.gamma);
    f.attribute("/", "beta", coef.beta);
    f.attribute("/", "youngs_modulus_Pa", scene.youngs_modulus);
    f.attribute("/", "poisson_ratio", scene.poisson_ratio);
    f.attribute("/", "density_kg_m3", scene.density);
    f.attribute("/", "rayleigh_alpha_1_s", scene.rayleigh_alpha);
    f.attribute("/", "rayleigh_beta_s", scene.rayleigh_beta);
    f.attribute("/", "fe_degree", static_cast<long long>(scene.fe_degree));
    f.attribute("/", "mass_matrix", std::string(scene.one_point_mass ? "one_point" : "consistent"));
    f.attribute("/", "mesh_file", scene.mesh_file);
    f.attribute("/", "mesh_hash", file_hash(scene.mesh_file));
    f.attribute("/", "fixed_surfaces", fixed);
    f.attribute("/", "scene", scene.json_text);
  }
} // namespace irdm::fem
