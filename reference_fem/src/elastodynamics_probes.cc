// ElasticDynamics: probes that touch the surface between vertices, or over a patch of
// vertices within a contact radius (scene.probes).
//
// The step solves K_eff u = rhs + scale * f_c with the contact forces f_c = B^T lambda, where
// B spreads each probe's 3 components over its vertices: the vertices of its contact triangle
// by barycentric weights, or a radius probe's patch by geometry::radius_patch. With
// X_i = K_eff^{-1} e_i (cached per touched DoF), the probes' compliance is
// S = scale * B X B^T and lambda solves S lambda = g - B u_free (irdm_common/contact.h, the same
// active-set rule the IRDM runtime uses).
#include <irdm_common/contact.h>
#include <irdm_common/error.h>
#include <irdm_common/geometry.h>

#include "elastodynamics_impl.h"

#include <Eigen/Dense>

#include <chrono>

namespace irdm::fem
{
  const Vector<double> &
  ElasticDynamics::Impl::probe_column(const types::global_dof_index dof) const
  {
    auto it = probe_columns.find(dof);
    if (it == probe_columns.end())
      {
        Vector<double> x(dof_handler.n_dofs());
        x[dof] = 1.0;
        constraints.set_zero(x);
        stepper().inverse.solve(x);
        it = probe_columns.emplace(dof, std::move(x)).first;
      }
    return it->second;
  }

  ElasticDynamics::Impl::ProbeSpread
  ElasticDynamics::Impl::probe_spread(const unsigned p, const double t) const
  {
    const Probe &probe = scene.probes[p];
    ProbeSpread  out;
    out.at = geometry::closest_point(mesh.vertices, probe_triangles[p], probe.path.at(t));
    if (probe.radius <= 0)
      {
        for (int i = 0; i < 3; ++i)
          {
            out.vertices.push_back(probe_triangles[p][out.at.triangle][i]);
            out.weights.push_back(out.at.weights[i]);
          }
        return out;
      }
    // No cap here (the FEM's patch may be larger than the runtime's contact::max_patch).
    const int cap = static_cast<int>(3 * probe_triangles[p].size());
    out.vertices.resize(cap);
    out.weights.resize(cap);
    const int n = geometry::radius_patch(mesh.vertices, probe_triangles[p], out.at.point,
                                         probe.radius, out.vertices.data(), out.weights.data(),
                                         cap);
    if (n == 0)
      throw InputError("probe '" + probe.name + "': at t = " + std::to_string(t) +
                       " s no surface vertex lies within its radius_m " +
                       std::to_string(probe.radius) +
                       " of its contact point: the radius must exceed the mesh size there");
    out.vertices.resize(n);
    out.weights.resize(n);
    return out;
  }

  std::vector<std::array<double, 10>>
  ElasticDynamics::Impl::solve_probes(const double t, const double scale, Vector<double> &u,
                                      Vector<double> &f) const
  {
    const int P = static_cast<int>(scene.probes.size());
    std::vector<ProbeSpread> at(P);
    for (int p = 0; p < P; ++p)
      at[p] = probe_spread(p, t);
    const auto dof = [&](const int p, const size_t i, const int d) {
      return dofs_of_vertex[at[p].vertices[i]][d];
    };
    contact::Matrix S(3 * P, 3 * P);
    contact::Vector gap(3 * P), lambda(3 * P);
    std::array<contact::ProbeRule, contact::max_probes> rules;
    std::array<double, contact::max_probes>             compliance{};
    for (int p = 0; p < P; ++p)
      {
        const double depth = scene.probes[p].depth.at(t);
        rules[p]           = {scene.probes[p].direction, scene.probes[p].unilateral,
                              t <= scene.probes[p].until};
        // The device's displacement now and one step before; a coupled probe prescribes the
        // coupling's target z instead (contact::Coupling), from the point's last displacement.
        const auto  &pr = scene.probes[p];
        const double depth_before = pr.depth.at(t - scene.time_step);
        std::array<double, 3> device, device_before, u_before;
        for (int d = 0; d < 3; ++d)
          {
            device[d]        = depth * pr.direction[d];
            device_before[d] = depth_before * pr.direction[d];
            u_before[d]      = last_probe.empty() ? 0.0 : last_probe[p][7 + d];
          }
        const contact::Coupling coupling{pr.coupling_stiffness, pr.coupling_damping};
        const auto target = coupling.target(device, device_before, u_before, scene.time_step);
        compliance[p]     = coupling.compliance(scene.time_step);
        for (int d = 0; d < 3; ++d)
          {
            double u_probe = 0;
            for (size_t i = 0; i < at[p].vertices.size(); ++i)
              u_probe += at[p].weights[i] * u[dof(p, i, d)];
            gap[3 * p + d] = target[d] - u_probe;
          }
      }
    for (int q = 0; q < P; ++q)
      for (int e = 0; e < 3; ++e)
        for (int p = 0; p < P; ++p)
          for (int d = 0; d < 3; ++d)
            {
              double s = 0;
              for (size_t j = 0; j < at[q].vertices.size(); ++j)
                {
                  const Vector<double> &x = probe_column(dof(q, j, e));
                  for (size_t i = 0; i < at[p].vertices.size(); ++i)
                    s += at[p].weights[i] * at[q].weights[j] * x[dof(p, i, d)];
                }
              S(3 * p + d, 3 * q + e) = scale * s;
            }
    for (int p = 0; p < P; ++p)
      for (int d = 0; d < 3; ++d)
        S(3 * p + d, 3 * p + d) += compliance[p];
    bool active[contact::max_probes];
    contact::solve_active_set(S, gap, rules.data(), P, lambda, active);

    std::vector<std::array<double, 10>> out(P);
    for (int q = 0; q < P; ++q)
      {
        for (int e = 0; e < 3; ++e)
          if (lambda[3 * q + e] != 0)
            for (size_t j = 0; j < at[q].vertices.size(); ++j)
              {
                const double fj = at[q].weights[j] * lambda[3 * q + e];
                u.add(scale * fj, probe_column(dof(q, j, e)));
                f[dof(q, j, e)] += fj;
              }
        const auto &c = at[q].at.point;
        out[q] = {lambda[3 * q], lambda[3 * q + 1], lambda[3 * q + 2], c[0], c[1], c[2],
                  active[q] ? 1.0 : 0.0, 0, 0, 0};
      }
    for (int q = 0; q < P; ++q)
      for (int d = 0; d < 3; ++d)
        for (size_t j = 0; j < at[q].vertices.size(); ++j)
          out[q][7 + d] += at[q].weights[j] * u[dof(q, j, d)];
    return out;
  }

  ProbeCompliance
  ElasticDynamics::probe_compliance(const double t) const
  {
    const Impl &m = *impl_;
    if (m.constraints.n_constraints() == 0)
      throw InputError("a probe's static stiffness needs a fixed surface (scene key "
                       "'fixed_surfaces'): a free body has no static state");
    const int P = static_cast<int>(m.scene.probes.size());
    if (P == 0)
      throw InputError("scene '" + m.scene.name + "' has no probes (scene key 'probes')");
    const auto t0 = std::chrono::steady_clock::now();
    std::vector<Impl::ProbeSpread> at(P);
    for (int p = 0; p < P; ++p)
      at[p] = m.probe_spread(p, t);
    // K^-1 B^T, one column per probe component: a static solve with the stiffness alone.
    DirectSolver k_inverse;
    k_inverse.initialize(m.condensed(m.stiffness));
    Eigen::MatrixXd S(3 * P, 3 * P);
    Vector<double>  x(m.dof_handler.n_dofs());
    for (int q = 0; q < P; ++q)
      for (int e = 0; e < 3; ++e)
        {
          x = 0;
          for (size_t j = 0; j < at[q].vertices.size(); ++j)
            x[m.dofs_of_vertex[at[q].vertices[j]][e]] += at[q].weights[j];
          m.constraints.set_zero(x);
          k_inverse.solve(x);
          for (int p = 0; p < P; ++p)
            for (int d = 0; d < 3; ++d)
              {
                double s = 0;
                for (size_t i = 0; i < at[p].vertices.size(); ++i)
                  s += at[p].weights[i] * x[m.dofs_of_vertex[at[p].vertices[i]][d]];
                S(3 * p + d, 3 * q + e) = s;
              }
        }
    ProbeCompliance out;
    for (int i = 0; i < 3 * P; ++i)
      for (int j = 0; j < 3 * P; ++j)
        out.compliance.push_back(S(i, j));
    for (int p = 0; p < P; ++p)
      {
        const Eigen::Matrix3d    Spp = S.block<3, 3>(3 * p, 3 * p);
        const auto              &dir = m.scene.probes[p].direction;
        const Eigen::Vector3d    d(dir[0], dir[1], dir[2]);
        out.stiffness.push_back(d.dot(Spp.ldlt().solve(d)));
        out.n_vertices.push_back(static_cast<unsigned>(at[p].vertices.size()));
        out.point.push_back(at[p].at.point);
      }
    out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    return out;
  }
} // namespace irdm::fem
