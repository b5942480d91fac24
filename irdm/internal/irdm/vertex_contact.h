#pragma once
// Many-vertex plane contact (issue 13): every free surface vertex of the model may touch any
// of up to contact::max_planes frictionless planes (a floor and a wall at once), each moving as
// the caller prescribes. Units SI. Frictionless: a plane pushes only along its normal.
//
// Each step, with the planes where they are at the end of the step:
//   candidates  c = (plane p, vertex v) with n_p . (X_v - x_p) < margin (X_v undeformed), or,
//               given a bound `reach` on how far the deformation has moved any vertex and a
//               test `deformed` (the modal kind's), with n_p . (X_v + u_v - x_p) < margin, u_v
//               the vertex's displacement at the step's start (asked only of the vertices
//               within margin + reach): the rows that may touch; the rest are assumed far
//               enough not to reach the plane within the step (the margin must exceed the
//               surface's motion toward it within one step). Without the deformed test a
//               vertex the deformation carries more than the margin toward a plane passes it
//               unseen, then meets it deep (the soft free cat gained energy so: reports/free).
//               The direct kind (PointInteraction) has no cheap displacement and takes the
//               undeformed test alone: keep its deformation toward a plane within the margin;
//   history     h_c = n_p . u_hist(v), u_hist = sum_{s>=1} H[s] f[n - s] at the candidate rows
//               only (O(modes x candidates) from the modal model, which keeps each row's
//               projection n_p^T Phi_v in a slot while the row stays a candidate: one dot
//               product per kept row instead of three);
//   gaps        q_c = n_p . (X_v + u_hist(v) - x_p), what the step reaches with no contact;
//   feed-through W_cd = n_p^T H[0](v_c <- v_d) n_q, + 1/k_c on the diagonal for a compliant
//               plane: per-vertex stiffness k_c (N/m; the force is k_c times the
//               penetration, solved implicitly, so a stiff wall does not chatter), either the
//               plane's `stiffness` for every vertex or its `penalty` (Pa/m) times the vertex's
//               lumped area, as the nonlinear FEM's P1 penalty weighs its vertices, + 1/c_p
//               on every pair of rows of a device-held plate (its coupling's compliance);
//   forces      lambda >= 0 complementary to g = W lambda + q >= 0
//               (irdm_common/complementarity.h: block principal pivoting, exact to round-off,
//               warm-started from the last step's contact set);
//   fallbacks   a step is never refused for its contact: with more candidates than
//               max_candidates, the deepest max_candidates (by their gap, as deformed where the
//               deformed test took it) are solved and the rest left out this step
//               (limited_steps()); when the solve refuses (a W that is not positive definite,
//               or more rounds than it allows), projected Gauss-Seidel from its last iterate
//               gives an approximate answer (fallback_steps());
//   history     f[n] += lambda_c n_p on vertex v_c.
// The full surface follows on demand from the runtime's surface_displacement().
//
// A runtime kind (PointInteraction: the direct model; ModalInteraction: the modal one) owns one
// VertexContact and drives it through detail::vertex_contact_step (irdm/src). Memory is sized
// at construction: the step allocates nothing and takes no lock.
#include <irdm/model.h>
#include <irdm/rigid_body.h>
#include <irdm_common/complementarity.h>

#include <Eigen/Core>

#include <array>
#include <vector>

namespace irdm
{
  namespace contact
  {
    constexpr int max_planes = 8;
  }

  /// Lumped area (m^2) of each output vertex: a third of every surface triangle it is a corner
  /// of. A P1 penalty wall of p Pa/m (the nonlinear FEM's, integrated at the face vertices)
  /// pushes vertex v with stiffness p times this.
  inline std::vector<double>
  lumped_vertex_areas(const ModelFrame &m)
  {
    std::vector<double> area(m.n_outputs / 3, 0.0);
    const auto          at = [&](const unsigned v) {
      const auto &x = m.output_coordinates[v];
      return Eigen::Vector3d(x[0], x[1], x[2]);
    };
    for (const auto &t : m.triangles)
      {
        const double a = (at(t[1]) - at(t[0])).cross(at(t[2]) - at(t[0])).norm() / 6;
        for (const unsigned v : t)
          area[v] += a;
      }
    return area;
  }

  /// A plane in the model's frame during one step.
  struct PlaneTarget
  {
    std::array<double, 3> normal    = {0, 0, 1}; // unit, toward the body
    std::array<double, 3> point     = {0, 0, 0}; // m, a point of the plane at the step's end
    double                stiffness = 0;         // N/m per vertex; 0: rigid
    // Pa/m: a penalty wall, each vertex's stiffness this times its lumped area
    // (lumped_vertex_areas), the nonlinear FEM's P1 penalty; when > 0 it replaces `stiffness`.
    double penalty = 0;
    // m/N: a device-held plate's virtual coupling 1 / (k + b / tau) (contact::Coupling), with
    // `point` its target z; the plate then stands at z - compliance (F . n) n, F the plane's
    // force. All its rows share this compliance. 0: the plane is at `point`.
    double coupling_compliance = 0;
  };

  struct VertexContactOptions
  {
    double   margin         = 0.005; // m, see above
    unsigned max_candidates = 512;   // rows of the complementarity problem, at most
  };

  /// What a step gives, per plane.
  struct PlaneContactResult
  {
    std::array<double, 3> force{}; // N, on the body
    int    candidates  = 0;        // vertices near the plane
    int    active      = 0;        // vertices it pushes
    double penetration = 0;        // m, deepest n . (x_p - x) over its candidates after the step
  };

  class VertexContact
  {
  public:
    void
    reset(const ModelFrame &m, const VertexContactOptions &o)
    {
      options_ = o;
      const size_t cap = o.max_candidates, n_vertices = m.n_outputs / 3;
      solver_.reserve(static_cast<int>(cap));
      plane_.assign(cap, 0);
      vertex_.assign(cap, 0);
      slot_.assign(cap, 0);
      slot_taken_.assign(cap, 0);
      q_.assign(cap, 0.0);
      lambda_.assign(cap, 0.0);
      guess_.assign(cap, 0);
      W_.assign(cap * cap, 0.0);
      W_rigid_.assign(cap * cap, 0.0);
      lever_.assign(cap, Eigen::Vector3d::Zero());
      turn_.assign(cap, Eigen::Vector3d::Zero());
      start_u_.assign(cap, Eigen::Vector3d::Zero());
      start_known_.assign(cap, 0);
      was_active_.assign(contact::max_planes * n_vertices, 0);
      rank_gap_.assign(contact::max_planes * n_vertices, 0.0);
      gap_.assign(cap, 0.0);
      limited_steps_ = fallback_steps_ = 0;
      vertex_area_ = lumped_vertex_areas(m);
      n_candidates_ = 0;
      rounds_       = 0;
      n_deformed_   = 0;
      previous_.plane.assign(cap, 0);
      previous_.vertex.assign(cap, 0);
      previous_.slot.assign(cap, 0);
      previous_.W.assign(cap * cap, 0.0);
      previous_.row_of.assign(contact::max_planes * n_vertices, -1);
      previous_.n = previous_.n_planes = 0;
    }

    const PlaneContactResult &
    plane(const int p) const
    {
      return results_[p];
    }
    /// Rounds of the complementarity solve at the latest step (0: no candidate).
    int
    rounds() const
    {
      return rounds_;
    }
    /// Candidate rows at the latest step.
    int
    candidates() const
    {
      return n_candidates_;
    }
    const VertexContactOptions &
    options() const
    {
      return options_;
    }

    // The step, for the runtimes (irdm/src/vertex_contact_step.h). history(in_vertex,
    // out_vertex, normal, slot, fresh) returns normal . u_hist(out_vertex); slot (0 <=
    // slot < max_candidates) stays the row's while it stays a candidate with the same plane
    // normal, fresh says it was just given (a runtime may cache per slot, see ModalInteraction).
    // rigid (a free body's step, irdm/free_body.h): the rigid body's step compliance joins W.
    // It is rank 6, so it is added as mu n_c . n_b + r_c . T r_b with r_c = (X_c + u_c - C) x n_c
    // (one lever per row) rather than entry by entry.
    // displacement(in_vertex) (with rigid): the vertex's displacement at the step's start (m,
    // model frame), so that a candidate's lever is taken at the deformed point X + u, where
    // the free body's torque acts (FreeBody::step).
    // reach (m): no vertex's displacement at the step's start is longer; 0: the deformed test
    // is not made. deformed(in_vertex, normal, limit, u) -> bool: whether normal . u < limit
    // for the vertex's displacement u at the step's start, which it sets when true (and may
    // leave unset when false: a runtime may rule a vertex out by a cheaper bound).
    template <class History, class FeedThrough, class Push, class Displacement, class Deformed>
    bool
    step(const ModelFrame &m, const PlaneTarget *planes, int n_planes, History &&history,
         FeedThrough &&h0, Push &&push, const RigidStepCompliance *rigid,
         Displacement &&displacement, double reach, Deformed &&deformed);
    template <class History, class FeedThrough, class Push>
    bool
    step(const ModelFrame &m, const PlaneTarget *planes, int n_planes, History &&history,
         FeedThrough &&h0, Push &&push)
    {
      return step(
        m, planes, n_planes, history, h0, push, nullptr,
        [](unsigned) { return Eigen::Vector3d::Zero().eval(); }, 0.0,
        [](unsigned, const std::array<double, 3> &, double, Eigen::Vector3d &) { return false; });
    }
    /// Candidates the deformed test added at the latest step (vertices within the margin of
    /// a plane only as deformed).
    int
    deformed_candidates() const
    {
      return n_deformed_;
    }
    /// Steps that had more candidates than max_candidates and solved the deepest of them.
    unsigned long
    limited_steps() const
    {
      return limited_steps_;
    }
    /// Steps whose solve refused and which took projected Gauss-Seidel's answer instead.
    unsigned long
    fallback_steps() const
    {
      return fallback_steps_;
    }
    /// Sweeps of the projected Gauss-Seidel fallback: bounded, so that a refused solve costs
    /// at most this many passes over W.
    static constexpr int fallback_sweeps = 50;

  private:
    // The parts of step() (irdm/src/vertex_contact_step.h), in order.
    // Whether vertex v is a candidate of plane p (see above); rank: its gap, as deformed
    // where the deformed test took it (u then set, known true).
    template <class Deformed>
    bool
    is_candidate(const ModelFrame &m, const PlaneTarget &plane, unsigned v, double reach,
                 Deformed &&deformed, double &rank, bool &known, Eigen::Vector3d &u) const;
    // The candidates whose rank is at most `admit`; with admit infinite, -1 when there are more
    // than max_candidates, else the first max_candidates of them.
    template <class Deformed>
    int
    gather_candidates(const ModelFrame &m, const PlaneTarget *planes, int n_planes, double reach,
                      Deformed &&deformed, double admit);
    // The max_candidates-th smallest rank of all candidates.
    template <class Deformed>
    double
    deepest_rank_bound(const ModelFrame &m, const PlaneTarget *planes, int n_planes, double reach,
                       Deformed &&deformed);
    template <class History>
    void
    add_history(const ModelFrame &m, const PlaneTarget *planes, int n_planes, int n,
                History &&history);
    template <class Displacement>
    void
    set_levers(const ModelFrame &m, const PlaneTarget *planes, int n,
               const RigidStepCompliance &rigid, Displacement &&displacement);
    template <class FeedThrough>
    void
    assemble_feed_through(const ModelFrame &m, const PlaneTarget *planes, int n, FeedThrough &&h0);
    void
    remember_rows(const PlaneTarget *planes, int n_planes, int n, unsigned n_vertices);
    const double *
    with_rigid_compliance(const PlaneTarget *planes, int n, const RigidStepCompliance &rigid);
    template <class Push>
    void
    apply_forces(const ModelFrame &m, const PlaneTarget *planes, int n, Push &&push);
    // Candidate c's row at the last step (same plane, normal and stiffness), or -1.
    int
    old_row(int c, unsigned n_vertices) const
    {
      return same_plane_[plane_[c]]
               ? previous_.row_of[static_cast<size_t>(plane_[c]) * n_vertices + vertex_[c]]
               : -1;
    }
    unsigned
    input_dof(const ModelFrame &m, int c, int d) const
    {
      return 3u * static_cast<unsigned>(m.output_input_index[vertex_[c]]) + d;
    }

    VertexContactOptions                                  options_;
    std::array<bool, contact::max_planes>                 same_plane_{}; // as the last step's
    contact::ComplementaritySolver                        solver_;
    std::vector<int>                                      plane_;  // [candidate]
    std::vector<unsigned>                                 vertex_; // [candidate], output vertex
    std::vector<int>                                      slot_;   // [candidate]
    std::vector<char>                                     slot_taken_; // [slot]
    std::vector<double>                                   q_, lambda_, W_;
    // A free body's W: the rows' W (kept from step to step, as H[0] does not change) plus the
    // rigid compliance, whose levers move with the deformation; what the solver reads.
    std::vector<double>                                   W_rigid_;
    // [candidate] a free body's lever r_c = (X_c + u_c - C) x n_c and T r_c (T: tau^2/4 I^-1).
    std::vector<Eigen::Vector3d>                          lever_, turn_;
    // [candidate] its displacement at the step's start, where the deformed test took it
    // (start_known_), so that its lever does not ask for it again.
    std::vector<Eigen::Vector3d>                          start_u_;
    std::vector<char>                                     start_known_;
    std::vector<char>                                     guess_;
    std::vector<char> was_active_; // [plane][output vertex]: in contact at the last step
    std::vector<double> rank_gap_; // [candidate of every plane] scratch of deepest_rank_bound
    std::vector<double> gap_;      // [candidate] the gaps W lambda + q after the solve
    unsigned long       limited_steps_ = 0, fallback_steps_ = 0;
    std::vector<double> vertex_area_; // [output vertex] m^2, for a plane's penalty
    // N/m, candidate c's stiffness against its plane; 0: rigid.
    double
    stiffness(const PlaneTarget &p, const int c) const
    {
      return p.penalty > 0 ? p.penalty * vertex_area_[vertex_[c]] : p.stiffness;
    }
    int               n_candidates_ = 0, rounds_ = 0, n_deformed_ = 0;
    // The last step's rows and W: W does not change while the rows and the planes' normals and
    // stiffnesses do not (H[0] is constant), so the entries of rows kept are copied, not
    // gathered again from H[0] (9 scattered reads each).
    struct
    {
      std::vector<int>      plane;
      std::vector<unsigned> vertex;
      std::vector<int>      slot;
      std::vector<double>   W;
      std::vector<int>      row_of; // [plane][output vertex] -> row, -1: none
      int                   n = 0, n_planes = 0;
      std::array<PlaneTarget, contact::max_planes> planes{};
    } previous_;
    std::array<PlaneContactResult, contact::max_planes> results_{};
  };
} // namespace irdm
