// irdm precompute-vdof: the virtual-DOF model (plane contact, seed 001); mpirun-able.
#include "../command.h"

#include <irdm_common/files.h>
#include <reference_fem/scene.h>
#include <reference_fem/virtual_dof.h>

#include <cstdio>
#include <memory>
#include <string>

namespace irdm::cli
{
  namespace
  {
    struct PrecomputeVdofArgs
    {
      std::string scene, out, storage;
      unsigned    subdivisions = 2, length = 0;
      double      depth = 0.001, band = 0.001;
      bool        quiet = false, allow_large = false;
    };

    int
    run_precompute_vdof(const PrecomputeVdofArgs &a)
    {
      irdm::check_output_file("--out", a.out, {a.scene});
      const auto scene = irdm::fem::read_scene(a.scene);
      irdm::fem::VirtualDofOptions o;
      o.output         = a.out;
      o.subdivisions   = a.subdivisions;
      o.impulse_depth  = a.depth;
      o.band           = a.band;
      if (a.length > 0)
        o.length = a.length;
      o.double_storage = storage_choice(a.storage);
      o.allow_large    = a.allow_large;
      o.log            = stderr_log(a.quiet);
      const auto r = irdm::fem::precompute_virtual_dofs(scene, o);
      if (mpi_rank() == 0)
        std::printf("virtual DOF model %s: %u orientations x %u samples, %u surface vertices, "
                    "%d rank(s)\ntime: total %.2f s; per orientation mean %.2f s, max %.2f s "
                    "(one rank); %u Newton iterations\nimpulse forces %.4g to %.4g N\n",
                    o.output.c_str(), r.n_orientations, r.length, r.n_surface, r.ranks,
                    r.seconds_total, r.seconds_per_orientation_mean, r.seconds_per_orientation_max,
                    r.newton_iterations, r.impulse_force_min, r.impulse_force_max);
      if (mpi_rank() == 0 && r.free_body)
        std::printf("free body (no fixed surface): rigid motion taken out by the best fit, %.3g %% "
                    "of the recorded displacement on average, %.3g %% at most\n",
                    100 * r.rigid_share_mean, 100 * r.rigid_share_max);
      return 0;
    }
  } // namespace

  Command
  add_precompute_vdof(CLI::App &app)
  {
    auto pv = std::make_shared<PrecomputeVdofArgs>();
    auto *precompute_vdof = app.add_subcommand("precompute-vdof", "virtual-DOF model (plane contact, seed 001); mpirun-able");
    precompute_vdof->footer("Virtual degrees of freedom (seed 001): for each plane orientation (the vertices of a "
      "geodesic dome), hits the scene's body once with a rigid frictionless wall in "
      "the nonlinear FEM (neo-Hookean, penalty contact) and records the responses of the "
      "surface and of every virtual DOF to that impulse, per newton of wall force "
      "(docs/model-format.md). Uses the scene's mesh, material, damping, integrator, step, "
      "fixed surfaces and model length T; loads, probes and gravity are left out. A scene "
      "with no fixed surface is a free body: its rigid motion (the best rigid fit at every "
      "sample) is taken out of the responses (route 1 of issue 14). Under "
      "'mpirun -np N' the orientations are dealt to the ranks; rank 0 writes.");
    precompute_vdof->add_option("scene", pv->scene, "scene file (JSON)")->required()->check(CLI::ExistingFile);
    precompute_vdof->add_option("--out", pv->out, "model file to write")->required();
    precompute_vdof->add_option("--subdivisions", pv->subdivisions,
                                "icosahedron subdivisions: 10 * 4^S + 2 orientations")
      ->capture_default_str()
      ->check(CLI::Range(0u, 4u));
    precompute_vdof->add_option("--depth", pv->depth,
                                "m, the wall's penetration into the undeformed body during its "
                                "one step of contact")
      ->capture_default_str()
      ->check(CLI::Range(1e-7, 0.05));
    precompute_vdof->add_option("--band", pv->band,
                                "m, vertices within B of a plane at first contact define its "
                                "virtual DOF's displacement (the seed's 1 mm)")
      ->capture_default_str()
      ->check(CLI::Range(1e-7, 0.05));
    precompute_vdof->add_option("--length", pv->length, "samples per response T (overrides the scene)")
      ->check(CLI::Range(1u, 1000000u));
    precompute_vdof->add_option("--storage", pv->storage, storage_help)
      ->check(CLI::IsMember({"float", "double"}));
    precompute_vdof->add_flag("--allow-large", pv->allow_large,
                              "run even if the memory or disk estimate exceeds what is free");
    precompute_vdof->add_flag("--quiet", pv->quiet, "no progress on stderr");
    return {precompute_vdof, [pv] { return run_precompute_vdof(*pv); }, true};
  }
} // namespace irdm::cli
