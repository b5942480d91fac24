#pragma once
// Internal: the probe part of one force-loop step, the same for every kind of model (full H,
// representatives, modal). A model kind supplies three things:
//   history(i, j)  displacement of output DoF j (the output of input DoF i) from the forces
//                  of earlier steps (the sum over s >= 1 of H[s] f[n - s]);
//   h0(k, j)       H[0] from input DoF k to output DoF j (the direct feed-through);
//   push(k, f)     adds force f (N) on input DoF k to this step's force sample.
// Then, with B the spreading of each probe over its vertices (barycentric on its triangle, or
// a radius probe's patch weights),
//   S = B H_CC[0] B^T,  S lambda = ubar - B h_C,  f[n] = B^T lambda  (irdm_common/contact.h).
#include <irdm/point_interaction.h>

namespace irdm::detail
{
  inline bool
  can_touch(const ModelFrame &m, const int t)
  {
    if (t < 0 || t >= static_cast<int>(m.triangles.size()))
      return false;
    for (const unsigned v : m.triangles[t])
      if (m.output_input_index[v] < 0)
        return false;
    return true;
  }

  inline bool
  can_touch(const ModelFrame &m, const ProbeTarget &probe)
  {
    if (probe.n_patch == 0)
      return can_touch(m, probe.triangle);
    if (probe.n_patch < 0 || probe.n_patch > contact::max_patch)
      return false;
    for (int i = 0; i < probe.n_patch; ++i)
      if (probe.patch_vertices[i] >= m.output_input_index.size() ||
          m.output_input_index[probe.patch_vertices[i]] < 0)
        return false;
    return true;
  }

  /// The vertices a probe spreads over: its triangle's 3, or its patch.
  inline int
  spread_size(const ProbeTarget &probe)
  {
    return probe.n_patch > 0 ? probe.n_patch : 3;
  }
  inline unsigned
  spread_vertex(const ModelFrame &m, const ProbeTarget &probe, const int i)
  {
    return probe.n_patch > 0 ? probe.patch_vertices[i] : m.triangles[probe.triangle][i];
  }
  inline double
  spread_weight(const ProbeTarget &probe, const int i)
  {
    return probe.n_patch > 0 ? probe.patch_weights[i] : probe.weights[i];
  }

  template <class History, class FeedThrough, class Push>
  void
  probe_step(const ModelFrame &m, const ProbeTarget *probes, const int P, History &&history,
             FeedThrough &&h0, Push &&push, ProbeResults &out)
  {
    const auto in_dof = [&](int p, int i, int d) {
      return 3u * m.output_input_index[spread_vertex(m, probes[p], i)] + d;
    };
    const auto out_dof = [&](int p, int i, int d) {
      return 3u * spread_vertex(m, probes[p], i) + d;
    };
    contact::Matrix S(3 * P, 3 * P);
    contact::Vector gap(3 * P), lambda(3 * P), h_probe(3 * P);
    std::array<contact::ProbeRule, contact::max_probes> rules;
    for (int p = 0; p < P; ++p)
      {
        rules[p] = {probes[p].direction, probes[p].unilateral, probes[p].present};
        for (int d = 0; d < 3; ++d)
          {
            double h = 0;
            for (int i = 0; i < spread_size(probes[p]); ++i)
              h += spread_weight(probes[p], i) * history(in_dof(p, i, d), out_dof(p, i, d));
            h_probe[3 * p + d] = h;
            gap[3 * p + d]     = probes[p].displacement[d] - h;
          }
      }
    for (int p = 0; p < P; ++p)
      for (int d = 0; d < 3; ++d)
        for (int q = 0; q < P; ++q)
          for (int e = 0; e < 3; ++e)
            {
              double s = 0;
              for (int i = 0; i < spread_size(probes[p]); ++i)
                for (int j = 0; j < spread_size(probes[q]); ++j)
                  s += spread_weight(probes[p], i) * spread_weight(probes[q], j) *
                       h0(in_dof(q, j, e), out_dof(p, i, d));
              S(3 * p + d, 3 * q + e) = s;
            }
    // The probed points move by S lambda; the coupling's compliance adds only to the spring.
    const contact::Matrix S_body = S;
    for (int p = 0; p < P; ++p)
      for (int d = 0; d < 3; ++d)
        S(3 * p + d, 3 * p + d) += probes[p].compliance;
    bool active[contact::max_probes];
    contact::solve_active_set(S, gap, rules.data(), P, lambda, active);

    const contact::Vector u_probe = h_probe + S_body * lambda;
    for (int q = 0; q < P; ++q)
      {
        out.active[q] = active[q];
        for (int e = 0; e < 3; ++e)
          {
            out.force[q][e]        = lambda[3 * q + e];
            out.displacement[q][e] = u_probe[3 * q + e];
            if (lambda[3 * q + e] != 0)
              for (int j = 0; j < spread_size(probes[q]); ++j)
                push(in_dof(q, j, e), spread_weight(probes[q], j) * lambda[3 * q + e]);
          }
      }
  }
} // namespace irdm::detail
