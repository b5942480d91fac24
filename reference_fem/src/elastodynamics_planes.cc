// ElasticDynamics: planes by vertex contact (scene.planes with linear kinematics), the contact
// the IRDM runtime does (irdm/vertex_contact.h), so that untruncated IRDM can be checked
// against it to round-off.
//
// Each step solves K_eff u = rhs + scale * f_c with f_c = sum_c lambda_c n_c e_(v_c): a normal
// force lambda_c >= 0 at free surface vertex v_c for each plane c touches. With
// X_i = K_eff^{-1} e_i (the probes' column cache), the gaps after the step are
//   g = W lambda + q,  W_cd = scale n_c^T X(v_c <- v_d) n_d (+ 1/k on the diagonal of a
//   compliant plane),  q_c = n_c . (X_v + u_free(v) - x_c),
// solved by the same complementarity solver as the runtime (irdm_common/complementarity.h).
// Rows: the vertices whose free gap is below zero, then any vertex the solution pushes past a
// plane, until none is; so the result is the complementarity problem over every free surface
// vertex, whatever the runtime's candidate margin.
#include <irdm_common/complementarity.h>
#include <irdm_common/contact.h>
#include <irdm_common/error.h>

#include "elastodynamics_impl.h"

#include <algorithm>
#include <cmath>

namespace irdm::fem
{
  namespace
  {
    double
    dot3(const Vec3 &a, const Vec3 &b)
    {
      return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    }
  } // namespace

  std::vector<PlaneSample>
  ElasticDynamics::Impl::solve_planes(const double t, const double scale, Vector<double> &u,
                                      Vector<double> &f) const
  {
    const unsigned           P = scene.planes.size();
    std::vector<PlaneSample> out(P);
    std::vector<Vec3>        at(P);
    // A device-held plate (contact::Coupling): its target z from the device now and one step
    // before and the plate one step before; the plate sits at z - (F . n) / c along n, so all
    // rows of one plate share the compliance 1 / c (W_cd += 1 / c on them).
    std::vector<double> coupling(P);
    for (unsigned p = 0; p < P; ++p)
      {
        const auto             &pl = scene.planes[p];
        const contact::Coupling c{pl.coupling_stiffness, pl.coupling_damping};
        coupling[p] = c.compliance(scene.time_step);
        at[p] = c.target(pl.position.at(t), pl.position.at(t - scene.time_step), plate_before[p],
                         scene.time_step);
      }
    std::vector<unsigned> free_vertices;
    for (const unsigned v : surface_vertices)
      if (!constraints.is_constrained(dofs_of_vertex[v][0]))
        free_vertices.push_back(v);
    const auto gap = [&](const unsigned p, const unsigned v, const Vector<double> &x) {
      Vec3 y;
      for (int d = 0; d < 3; ++d)
        y[d] = mesh.vertices[v][d] + x[dofs_of_vertex[v][d]] - at[p][d];
      return dot3(scene.planes[p].normal, y);
    };
    std::vector<std::pair<unsigned, unsigned>> rows; // (plane, vertex)
    for (unsigned p = 0; p < P; ++p)
      for (const unsigned v : free_vertices)
        if (gap(p, v, u) < 0)
          rows.emplace_back(p, v);
    std::vector<double> lambda, give(P, 0.0);
    Vector<double>      u_after(u);
    for (unsigned round = 0; !rows.empty(); ++round)
      {
        const int           n = static_cast<int>(rows.size());
        std::vector<double> W(static_cast<size_t>(n) * n), q(n);
        std::vector<char>   active(n, 1);
        for (int c = 0; c < n; ++c)
          {
            const auto [p, v] = rows[c];
            const Vec3 &nc    = scene.planes[p].normal;
            q[c]              = gap(p, v, u);
            for (int b = 0; b <= c; ++b)
              {
                const Vec3 &nb = scene.planes[rows[b].first].normal;
                double      s  = 0;
                for (int e = 0; e < 3; ++e)
                  {
                    const Vector<double> &x = probe_column(dofs_of_vertex[rows[b].second][e]);
                    for (int d = 0; d < 3; ++d)
                      s += nc[d] * nb[e] * x[dofs_of_vertex[v][d]];
                  }
                W[static_cast<size_t>(c) * n + b] = scale * s + (rows[b].first == p ? coupling[p] : 0);
              }
            if (scene.planes[p].vertex_stiffness > 0)
              W[static_cast<size_t>(c) * n + c] += 1 / scene.planes[p].vertex_stiffness;
          }
        contact::ComplementaritySolver solver(n);
        lambda.assign(n, 0.0);
        if (solver.solve(n, W.data(), n, q.data(), active.data(), lambda.data()) < 0)
          throw InputError("plane contact at t = " + std::to_string(t) +
                           " s: the complementarity solve failed (the contact rows' "
                           "compliance is not positive definite)");
        u_after = u;
        for (int c = 0; c < n; ++c)
          if (lambda[c] > 0)
            for (int e = 0; e < 3; ++e)
              u_after.add(scale * lambda[c] * scene.planes[rows[c].first].normal[e],
                          probe_column(dofs_of_vertex[rows[c].second][e]));
        double q_scale = 0;
        for (const double x : q)
          q_scale = std::max(q_scale, std::abs(x));
        // How far each plate stands back from its target: (F . n) / c.
        std::fill(give.begin(), give.end(), 0.0);
        for (int c = 0; c < n; ++c)
          give[rows[c].first] += coupling[rows[c].first] * lambda[c];
        // A vertex pushed past a plane by the others' contact becomes a row; then solve again.
        std::vector<std::pair<unsigned, unsigned>> more;
        for (unsigned p = 0; p < P; ++p)
          for (const unsigned v : free_vertices)
            if (gap(p, v, u_after) + give[p] < -contact::ComplementaritySolver::tolerance * q_scale &&
                std::find(rows.begin(), rows.end(), std::make_pair(p, v)) == rows.end())
              more.emplace_back(p, v);
        if (more.empty())
          break;
        if (round > 20)
          throw InputError("plane contact at t = " + std::to_string(t) +
                           " s: the contact rows did not settle in 20 rounds");
        rows.insert(rows.end(), more.begin(), more.end());
      }
    for (size_t c = 0; c < rows.size(); ++c)
      if (lambda[c] > 0)
        for (int e = 0; e < 3; ++e)
          {
            const double fe = lambda[c] * scene.planes[rows[c].first].normal[e];
            f[dofs_of_vertex[rows[c].second][e]] += fe;
            out[rows[c].first].force[e] += fe;
          }
    u = u_after;
    for (unsigned p = 0; p < P; ++p)
      {
        out[p].penetration = -1e300;
        for (const unsigned v : free_vertices)
          out[p].penetration = std::max(out[p].penetration, -gap(p, v, u) - give[p]);
        for (int d = 0; d < 3; ++d)
          plate_before[p][d] = at[p][d] - give[p] * scene.planes[p].normal[d];
      }
    return out;
  }
} // namespace irdm::fem
