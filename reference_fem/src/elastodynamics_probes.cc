// ElasticDynamics: probes that touch the surface between vertices (scene.probes).
//
// The step solves K_eff u = rhs + scale * f_c with the contact forces f_c = B^T lambda, where
// B spreads each probe's 3 components over the vertices of its contact triangle by barycentric
// weights. With X_i = K_eff^{-1} e_i (cached per touched DoF), the probes' compliance is
// S = scale * B X B^T and lambda solves S lambda = g - B u_free (irdm_common/contact.h, the same
// active-set rule the IRDM runtime uses).
#include <irdm_common/contact.h>
#include <irdm_common/geometry.h>

#include "elastodynamics_impl.h"

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
        step_solver.inverse.solve(x);
        it = probe_columns.emplace(dof, std::move(x)).first;
      }
    return it->second;
  }

  std::vector<std::array<double, 10>>
  ElasticDynamics::Impl::solve_probes(const double t, const double scale, Vector<double> &u,
                                      Vector<double> &f) const
  {
    const int P = static_cast<int>(scene.probes.size());
    // Contact triangles and weights at t.
    std::vector<std::array<unsigned, 3>> tri(P);
    std::vector<geometry::SurfacePoint> at(P);
    for (int p = 0; p < P; ++p)
      {
        at[p]  = geometry::closest_point(mesh.vertices, probe_triangles[p],
                                         scene.probes[p].path.at(t));
        tri[p] = probe_triangles[p][at[p].triangle];
      }
    const auto dof = [&](const int p, const int i, const int d) {
      return dofs_of_vertex[tri[p][i]][d];
    };
    contact::Matrix S(3 * P, 3 * P);
    contact::Vector gap(3 * P), lambda(3 * P);
    std::array<contact::ProbeRule, contact::max_probes> rules;
    for (int p = 0; p < P; ++p)
      {
        const double depth = scene.probes[p].depth.at(t);
        rules[p]           = {scene.probes[p].direction, scene.probes[p].unilateral,
                              t <= scene.probes[p].until};
        for (int d = 0; d < 3; ++d)
          {
            double u_probe = 0;
            for (int i = 0; i < 3; ++i)
              u_probe += at[p].weights[i] * u[dof(p, i, d)];
            gap[3 * p + d] = depth * scene.probes[p].direction[d] - u_probe;
          }
      }
    for (int q = 0; q < P; ++q)
      for (int e = 0; e < 3; ++e)
        for (int p = 0; p < P; ++p)
          for (int d = 0; d < 3; ++d)
            {
              double s = 0;
              for (int j = 0; j < 3; ++j)
                {
                  const Vector<double> &x = probe_column(dof(q, j, e));
                  for (int i = 0; i < 3; ++i)
                    s += at[p].weights[i] * at[q].weights[j] * x[dof(p, i, d)];
                }
              S(3 * p + d, 3 * q + e) = scale * s;
            }
    bool active[contact::max_probes];
    contact::solve_active_set(S, gap, rules.data(), P, lambda, active);

    std::vector<std::array<double, 10>> out(P);
    for (int q = 0; q < P; ++q)
      {
        for (int e = 0; e < 3; ++e)
          if (lambda[3 * q + e] != 0)
            for (int j = 0; j < 3; ++j)
              {
                const double fj = at[q].weights[j] * lambda[3 * q + e];
                u.add(scale * fj, probe_column(dof(q, j, e)));
                f[dof(q, j, e)] += fj;
              }
        out[q] = {lambda[3 * q], lambda[3 * q + 1], lambda[3 * q + 2], at[q].point[0],
                  at[q].point[1], at[q].point[2], active[q] ? 1.0 : 0.0, 0, 0, 0};
      }
    for (int q = 0; q < P; ++q)
      for (int d = 0; d < 3; ++d)
        for (int j = 0; j < 3; ++j)
          out[q][7 + d] += at[q].weights[j] * u[dof(q, j, d)];
    return out;
  }
} // namespace irdm::fem
