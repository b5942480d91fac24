#pragma once
// Internal: VertexContact::step (irdm/vertex_contact.h), the same for every model kind. The
// kind supplies:
//   history(vi, vo, n, slot, fresh)  n . (displacement of output vertex vo, the output of input
//                  vertex vi, from earlier forces); slot and fresh as in vertex_contact.h;
//   h0(k, j)       H[0] from input DoF k to output DoF j;
//   push(k, f)     adds force f (N) on input DoF k to this step's sample.
#include <irdm/vertex_contact.h>

#include <algorithm>
#include <cmath>

namespace irdm
{
  namespace detail
  {
    inline double
    dot(const std::array<double, 3> &a, const std::array<double, 3> &b)
    {
      return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    }
  } // namespace detail

  template <class History, class FeedThrough, class Push, class Displacement, class Deformed>
  bool
  VertexContact::step(const ModelFrame &m, const PlaneTarget *planes, const int n_planes,
                      History &&history, FeedThrough &&h0, Push &&push,
                      const RigidStepCompliance *rigid, Displacement &&displacement,
                      const double reach, Deformed &&deformed)
  {
    if (n_planes < 0 || n_planes > contact::max_planes)
      return false;
    int n = gather_candidates(m, planes, n_planes, reach, deformed, INFINITY);
    if (n < 0)
      {
        // More vertices near the planes than rows: the deepest max_candidates, counted.
        const double admit = deepest_rank_bound(m, planes, n_planes, reach, deformed);
        n                  = gather_candidates(m, planes, n_planes, reach, deformed, admit);
        ++limited_steps_;
      }
    std::fill(was_active_.begin(), was_active_.end(), 0); // O(planes x vertices), cheap
    rounds_ = 0;
    if (n == 0)
      return true;
    add_history(m, planes, n_planes, n, history);
    if (rigid)
      set_levers(m, planes, n, *rigid, displacement);
    assemble_feed_through(m, planes, n, h0);
    remember_rows(planes, n_planes, n, m.n_outputs / 3);
    const double *W = rigid ? with_rigid_compliance(planes, n, *rigid) : previous_.W.data();
    const int    ldw = static_cast<int>(options_.max_candidates);
    rounds_          = solver_.solve(n, W, ldw, q_.data(), guess_.data(), lambda_.data());
    if (rounds_ >= 0)
      for (int c = 0; c < n; ++c)
        gap_[c] = solver_.g(c);
    else
      {
        contact::projected_gauss_seidel(n, W, ldw, q_.data(), lambda_.data(), fallback_sweeps, gap_.data());
        ++fallback_steps_;
      }
    apply_forces(m, planes, n, push);
    return true;
  }

  template <class Deformed>
  bool
  VertexContact::is_candidate(const ModelFrame &m, const PlaneTarget &plane, const unsigned v,
                              const double reach, Deformed &&deformed, double &rank, bool &known,
                              Eigen::Vector3d &u) const
  {
    const int in = m.output_input_index[v];
    if (in < 0)
      return false;
    const auto  &nn  = plane.normal;
    const double gap = detail::dot(nn, m.output_coordinates[v]) - detail::dot(nn, plane.point);
    rank  = gap; // undeformed
    known = false;
    if (gap < options_.margin)
      return true;
    if (gap >= options_.margin + reach || !deformed(static_cast<unsigned>(in), nn, options_.margin - gap, u))
      return false;
    known = true;
    rank  = gap + u.dot(Eigen::Vector3d(nn[0], nn[1], nn[2]));
    return true;
  }

  // Candidates, with the last step's contact set as the solver's first guess: within the
  // margin undeformed, or as deformed (vertex_contact.h). Their gaps q_ start undeformed.
  template <class Deformed>
  int
  VertexContact::gather_candidates(const ModelFrame &m, const PlaneTarget *planes,
                                   const int n_planes, const double reach, Deformed &&deformed,
                                   const double admit)
  {
    const unsigned n_vertices = m.n_outputs / 3;
    const int      cap        = static_cast<int>(options_.max_candidates);
    int            n          = 0;
    n_deformed_               = 0;
    for (int p = 0; p < n_planes; ++p)
      {
        results_[p]     = PlaneContactResult{};
        for (unsigned v = 0; v < n_vertices; ++v)
          {
            double          rank  = 0;
            bool            known = false;
            Eigen::Vector3d u;
            if (!is_candidate(m, planes[p], v, reach, deformed, rank, known, u) || rank > admit)
              continue;
            if (n == cap)
              {
                if (std::isfinite(admit))
                  continue; // ties at the bound beyond the capacity: left out
                n_candidates_ = n;
                return -1;
              }
            plane_[n]       = p;
            vertex_[n]      = v;
            guess_[n]       = was_active_[static_cast<size_t>(p) * n_vertices + v];
            q_[n]           = detail::dot(planes[p].normal, m.output_coordinates[v]) -
                              detail::dot(planes[p].normal, planes[p].point);
            start_known_[n] = known;
            if (known)
              start_u_[n] = u, ++n_deformed_;
            ++results_[p].candidates;
            ++n;
          }
      }
    n_candidates_ = n;
    return n;
  }

  template <class Deformed>
  double
  VertexContact::deepest_rank_bound(const ModelFrame &m, const PlaneTarget *planes,
                                    const int n_planes, const double reach, Deformed &&deformed)
  {
    const unsigned n_vertices = m.n_outputs / 3;
    size_t         n          = 0;
    for (int p = 0; p < n_planes; ++p)
      for (unsigned v = 0; v < n_vertices; ++v)
        {
          double          rank  = 0;
          bool            known = false;
          Eigen::Vector3d u;
          if (is_candidate(m, planes[p], v, reach, deformed, rank, known, u))
            rank_gap_[n++] = rank;
        }
    const auto kth = rank_gap_.begin() + (options_.max_candidates - 1);
    std::nth_element(rank_gap_.begin(), kth, rank_gap_.begin() + n);
    return *kth;
  }

  // Rows kept from the last step (same plane normal and stiffness) keep their slot; new rows
  // take free slots. Each gap gets the history along its normal.
  template <class History>
  void
  VertexContact::add_history(const ModelFrame &m, const PlaneTarget *planes, const int n_planes,
                             const int n, History &&history)
  {
    const unsigned n_vertices = m.n_outputs / 3;
    for (int p = 0; p < n_planes; ++p)
      same_plane_[p] = p < previous_.n_planes && planes[p].normal == previous_.planes[p].normal &&
                       planes[p].stiffness == previous_.planes[p].stiffness &&
                       planes[p].penalty == previous_.planes[p].penalty &&
                       planes[p].coupling_compliance == previous_.planes[p].coupling_compliance;
    std::fill(slot_taken_.begin(), slot_taken_.end(), 0);
    for (int c = 0; c < n; ++c)
      {
        const int oc = old_row(c, n_vertices);
        slot_[c]     = oc >= 0 ? previous_.slot[oc] : -1;
        if (oc >= 0)
          slot_taken_[slot_[c]] = 1;
      }
    for (int c = 0, free_slot = 0; c < n; ++c)
      {
        const bool fresh = slot_[c] < 0;
        if (fresh)
          {
            while (slot_taken_[free_slot])
              ++free_slot;
            slot_[c]               = free_slot;
            slot_taken_[free_slot] = 1;
          }
        q_[c] += history(static_cast<unsigned>(m.output_input_index[vertex_[c]]), vertex_[c],
                         planes[plane_[c]].normal, slot_[c], fresh);
      }
  }

  // A free body's levers (the rigid compliance's rank-6 form, vertex_contact.h), at the
  // deformed points.
  template <class Displacement>
  void
  VertexContact::set_levers(const ModelFrame &m, const PlaneTarget *planes, const int n,
                            const RigidStepCompliance &rigid, Displacement &&displacement)
  {
    for (int c = 0; c < n; ++c)
      {
        const auto           &X  = m.output_coordinates[vertex_[c]];
        const auto           &nn = planes[plane_[c]].normal;
        const Eigen::Vector3d x =
          Eigen::Vector3d(X[0], X[1], X[2]) +
          (start_known_[c] ? start_u_[c]
                           : displacement(static_cast<unsigned>(m.output_input_index[vertex_[c]])));
        lever_[c] = (x - rigid.center).cross(Eigen::Vector3d(nn[0], nn[1], nn[2]));
        turn_[c]  = rigid.tau2_inverse_inertia * lever_[c];
      }
  }

  // W, lower triangle (the solver reads no more): W_cb = n_c^T H[0](c <- b) n_b, copied from
  // the last step where both rows were rows then; a compliant plane's 1/k and a plate's
  // coupling on top.
  template <class FeedThrough>
  void
  VertexContact::assemble_feed_through(const ModelFrame &m, const PlaneTarget *planes,
                                       const int n, FeedThrough &&h0)
  {
    const unsigned n_vertices = m.n_outputs / 3;
    const size_t   cap        = options_.max_candidates;
    for (int c = 0; c < n; ++c)
      {
        const auto &nc = planes[plane_[c]].normal;
        double     *w  = &W_[static_cast<size_t>(c) * cap];
        const int   oc = old_row(c, n_vertices);
        for (int b = 0; b <= c; ++b)
          {
            const int ob = oc < 0 ? -1 : old_row(b, n_vertices);
            if (ob >= 0)
              {
                w[b] = oc >= ob ? previous_.W[static_cast<size_t>(oc) * cap + ob]
                                : previous_.W[static_cast<size_t>(ob) * cap + oc];
                continue;
              }
            const auto &nb = planes[plane_[b]].normal;
            double      s  = 0;
            for (int e = 0; e < 3; ++e)
              {
                const unsigned k = input_dof(m, b, e);
                for (int d = 0; d < 3; ++d)
                  s += nc[d] * nb[e] * h0(k, 3u * vertex_[c] + d);
              }
            w[b] = s + (plane_[b] == plane_[c] ? planes[plane_[c]].coupling_compliance : 0.0);
          }
        const double k = stiffness(planes[plane_[c]], c);
        if (k > 0 && oc < 0)
          w[c] += 1 / k;
      }
  }

  // These rows and W for the next step; W moves to previous_.W, which the solver then reads.
  inline void
  VertexContact::remember_rows(const PlaneTarget *planes, const int n_planes, const int n,
                               const unsigned n_vertices)
  {
    for (int c = 0; c < previous_.n; ++c)
      previous_.row_of[static_cast<size_t>(previous_.plane[c]) * n_vertices + previous_.vertex[c]] = -1;
    for (int c = 0; c < n; ++c)
      {
        previous_.row_of[static_cast<size_t>(plane_[c]) * n_vertices + vertex_[c]] = c;
        previous_.plane[c]  = plane_[c];
        previous_.vertex[c] = vertex_[c];
        previous_.slot[c]   = slot_[c];
      }
    previous_.n        = n;
    previous_.n_planes = n_planes;
    std::copy(planes, planes + n_planes, previous_.planes.begin());
    std::swap(W_, previous_.W);
  }

  // The rigid compliance with this step's levers, on a copy: the rows kept next step take
  // their W without it.
  inline const double *
  VertexContact::with_rigid_compliance(const PlaneTarget *planes, const int n,
                                       const RigidStepCompliance &rigid)
  {
    const size_t cap = options_.max_candidates;
    for (int c = 0; c < n; ++c)
      {
        const auto   &nc = planes[plane_[c]].normal;
        const double *w  = &previous_.W[static_cast<size_t>(c) * cap];
        double       *wr = &W_rigid_[static_cast<size_t>(c) * cap];
        for (int b = 0; b <= c; ++b)
          wr[b] = w[b] + rigid.tau2_over_mass * detail::dot(nc, planes[plane_[b]].normal) +
                  lever_[c].dot(turn_[b]);
      }
    return W_rigid_.data();
  }

  // The solved forces into the results and, through push, into this step's force sample.
  template <class Push>
  void
  VertexContact::apply_forces(const ModelFrame &m, const PlaneTarget *planes, const int n,
                              Push &&push)
  {
    const unsigned n_vertices = m.n_outputs / 3;
    for (int c = 0; c < n; ++c)
      {
        auto &r = results_[plane_[c]];
        // The solve's gap includes a compliant plane's give lambda / k; the body's does not.
        const double k = stiffness(planes[plane_[c]], c);
        r.penetration  = std::max(r.penetration, (k > 0 ? lambda_[c] / k : 0) - gap_[c]);
        if (lambda_[c] <= 0)
          continue;
        const auto &nn = planes[plane_[c]].normal;
        ++r.active;
        was_active_[static_cast<size_t>(plane_[c]) * n_vertices + vertex_[c]] = 1;
        for (int d = 0; d < 3; ++d)
          {
            r.force[d] += lambda_[c] * nn[d];
            push(input_dof(m, c, d), lambda_[c] * nn[d]);
          }
      }
  }
} // namespace irdm
