#pragma once
// Surface contact by virtual degrees of freedom (seed 001): a rigid frictionless plane
// (floor, wall) against the grounded body, at run time, from the model 'irdm precompute-vdof'
// writes (docs/model-format.md). Units SI.
//
// The wall is given in the object's frame by a unit direction d (from the object toward the
// wall) and a position w (m): it occupies {x : d . x > w} and pushes along -d. Its orientation
// maps to the dome's virtual DOFs k_i with weights w_i (the nearest one, or barycentric in the
// dome triangle around d). Per step, with the wall force F (N, >= 0) split as f_{k_i} = w_i F:
//   y(d)[n] = sum_i w_i y_{k_i}[n] = h(d)[n] + c(d) F,   c(d) = sum_il w_i w_l Y_{k_i k_l}[0],
// where h is the history part (s >= 1) and c the feed-through (m/N). y_k is the mean recession
// of virtual DOF k's band (the free surface vertices within band_m of its plane at first
// contact), which rests at r_k = mean over the band of d_k . X. The wall is rigid and holds the
// band: r(d) - y(d) may not pass w, so F = max(0, (r(d) - h(d) - w) / c(d)). For a direction
// between the dome's, r(d) = support(d) - sum_i w_i (first_contact_k_i - r_k_i), support(d) the
// largest d . X over the free surface vertices: the exact support, less the band's interpolated
// depth. This is what the precompute did: its wall at first_contact_k - depth met a band resting
// at r_k (docs/model-format.md).
// The surface follows by convolution: u[n] = sum_k sum_s S_k[s] f_k[n - s].
#include <irdm/rigid_body.h>
#include <irdm_common/complementarity.h>

#include <array>
#include <string>
#include <vector>

namespace irdm
{
  struct VirtualDofModel
  {
    double   time_step = 0; // s
    unsigned length = 0, n_orientations = 0, n_surface = 0;
    std::vector<std::array<double, 3>>   directions;     // unit, per virtual DOF
    std::vector<std::array<unsigned, 3>> dome_triangles; // of directions
    std::vector<double>                  first_contact;  // m, support along each direction
    std::vector<double>                  rest_position;  // m, band mean of d_k . X
    std::vector<double>                  impulse_force;  // N, F_k of the precompute
    std::vector<float>                   surface_response; // [k][s][3 * vertex + axis], m/N
    std::vector<double>                  dof_response;     // [k][s][j], m/N
    std::vector<long long>               node_tags;
    std::vector<std::array<double, 3>>   coordinates; // m, undeformed surface vertices
    std::vector<char>                    fixed;       // per surface vertex: on a fixed surface
    std::vector<std::array<unsigned, 3>> triangles;
    std::string                          mesh_hash, integrator;
    double                               band = 0.001; // m, band_m of the precompute
    // A free body (format 3, body = free): the responses are the deformation left after the
    // best rigid fit (route 1); run it through FreeBodyVirtualDofs (irdm/free_body.h), which
    // makes the rigid motion from these mass properties (model frame).
    bool                                 free_body = false;
    // N/m per orientation: the precompute's penalty wall as a spring in series with the body,
    // F_k over its overlap with band k at the impulse step (format 3); empty in older files.
    std::vector<double>                  wall_stiffness;
    double                               mass = 0; // kg
    std::array<double, 3>                center_of_mass{};                  // m
    std::array<std::array<double, 3>, 3> inertia{}; // kg m^2, about the centre of mass

    double
    Y(unsigned k, unsigned s, unsigned j) const
    {
      return dof_response[(static_cast<size_t>(k) * length + s) * n_orientations + j];
    }
  };

  /// InputError for a missing file, a wrong format, bad shapes, non-finite data, or a time step
  /// different from expected_time_step (relative 1e-12) when one is given (> 0).
  VirtualDofModel
  load_virtual_dof_model(const std::string &path, double expected_time_step = 0);

  enum class OrientationMapping
  {
    nearest,      // the closest dome direction only
    interpolated, // barycentric among the three directions of the dome triangle around d
    // As interpolated, but only among those of the three whose first-contact vertex the wall
    // along d itself touches within the band (d . X_first >= support(d) - band), weights
    // renormalized; none: nearest. On a body that is not convex, neighbouring directions can
    // first touch different body parts; blending them splits the wall force over places the
    // wall does not touch, and their weak cross responses make the blended wall too stiff
    // (reports/planes/planes.md, "Nearest against interpolated orientation").
    interpolated_same_contact
  };

  struct OrientationWeights
  {
    unsigned                n = 0;
    std::array<unsigned, 3> k{};
    std::array<double, 3>   w{}; // >= 0, sum 1
  };

  OrientationWeights
  orientation_weights(const VirtualDofModel &m, const std::array<double, 3> &d,
                      OrientationMapping mapping);

  /// The support of the undeformed body along d: the free surface vertex farthest along d,
  /// and d . X there (m). The vertex a wall moving along -d first touches.
  struct SurfaceSupport
  {
    unsigned vertex   = 0;
    double   distance = -1e300;
  };
  SurfaceSupport
  surface_support(const VirtualDofModel &m, const std::array<double, 3> &d);

  /// One wall during one step: direction d (unit, from the object toward the wall), position
  /// w (m; the wall occupies {x : d . x > w}), and stiffness (N/m of the virtual DOF; 0: rigid;
  /// precompute_wall: the precompute's own penalty wall, VirtualDofModel::wall_stiffness of the
  /// mapped orientations, blended by their weights).
  struct VirtualDofWall
  {
    static constexpr double precompute_wall = -1;
    std::array<double, 3> direction = {0, 0, -1};
    double                position  = 0;
    double                stiffness = 0;
  };

  /// The force loop and the surface update of up to max_walls walls against the model. Several
  /// walls couple through the virtual DOFs' cross responses Y_jk: with the walls' forces F,
  ///   y_a = h_a + sum_b c_ab F_b,  c_ab = sum_il w_ai w_bl Y_{k_ai k_bl}[0],
  /// solved as a complementarity problem (irdm_common/complementarity.h). A compliant wall of
  /// stiffness k adds 1/k to c_aa (implicit). No allocation after construction.
  class PlaneInteraction
  {
  public:
    static constexpr int max_walls = 4;

    PlaneInteraction(const VirtualDofModel &model, OrientationMapping mapping);

    /// One step with one rigid wall at direction d (unit) and position w (m). Returns the
    /// wall's force (N) along -d; penetration() is how far the undeformed surface would pass
    /// the wall (m, negative: a gap).
    double
    step(const std::array<double, 3> &d, double w);

    /// One step with n <= max_walls walls; force[a] (N, along -d_a) out. Returns false if n is
    /// out of range or a wall asks for precompute_wall of a file without wall stiffness
    /// (format 2) (no step taken), or if the solve fails (the step is taken with no force).
    bool
    step(const VirtualDofWall *walls, int n, double *force);

    /// The same for a free body (irdm/free_body.h): the walls are in the model frame at the
    /// step's predicted pose, and the rigid body's own compliance over the step joins the
    /// feed-through, at each wall's contact point (contact_point): a wall force moves the body
    /// as well as denting it.
    bool
    step(const VirtualDofWall *walls, int n, double *force, const RigidStepCompliance &rigid);

    /// Where wall a's force acts at the latest free-body step (model frame, m): on the wall's
    /// plane, at the blend (by the orientation weights) of the mapped virtual DOFs' band
    /// centroids, where their precomputed hits pushed.
    std::array<double, 3>
    contact_point(int a) const
    {
      return walls_[a].point;
    }
    /// Direction d of wall a at the latest step (unit, model frame).
    const std::array<double, 3> &
    wall_direction(int a) const
    {
      return walls_[a].direction;
    }

    /// One step with a known wall force F (N, along -d) instead of a wall position: the force
    /// history and the surface follow it (open loop; to drive the model by a measured force).
    void
    apply(const std::array<double, 3> &d, double F);

    /// Surface displacement (m, [3 * vertex + axis]) at the latest step.
    const std::vector<double> &
    update_surface();

    /// Of the first wall at the latest step.
    double
    penetration() const
    {
      return walls_[0].penetration;
    }
    /// r(d) for the latest step's direction: where the band rests along d (m).
    double
    rest_position() const
    {
      return walls_[0].rest;
    }
    /// y(d) at the latest step: how far the surface at the wall has receded (m).
    double
    virtual_dof_displacement() const
    {
      return walls_[0].y;
    }
    unsigned
    steps() const
    {
      return n_;
    }

  private:
    const VirtualDofModel &m_;
    OrientationMapping     mapping_;
    unsigned               n_ = 0; // steps taken
    // Force history per virtual DOF in a ring stored twice (index n mod T and n mod T + T), so
    // that the T latest samples are contiguous: f_k[n - s] = ring[k][(n mod T) + T - s].
    std::vector<double>   ring_;
    std::vector<unsigned> last_active_; // last step + 1 with f_k != 0 (0: never)
    std::vector<double>   surface_;
    std::vector<std::array<double, 3>> band_centroid_; // per virtual DOF, model frame
    // Per wall: its mapping and the surface's support along its direction, kept while the
    // direction does not change (a floor or a wall moving along its normal).
    struct Mapped
    {
      std::array<double, 3> direction{};
      OrientationWeights    weights;
      double                support = 0, rest = 0, penetration = 0, y = 0;
      std::array<double, 3> point{}; // free body: where the force acts (contact_point)
    };
    std::array<Mapped, max_walls> walls_{};
    int                           n_walls_ = 0;
    contact::ComplementaritySolver solver_{max_walls};

    void
    map_direction(Mapped &wall, const std::array<double, 3> &d);
    void
    place_contact(Mapped &wall, double position) const; // sets wall.point
    bool
    solve(const VirtualDofWall *walls, int n, double *force, const RigidStepCompliance *rigid);
    double
    history(unsigned j) const; // sum_{k, s >= 1} Y_jk[s] f_k[n - s], n the step being taken
    void
    record(const double *F); // this step's wall forces into the history, split by the
                             // weights; ++n_
    double
    wall_history(const Mapped &a) const; // h of a mapped wall, this step
    double
    feed_through(const Mapped &a, const Mapped &b) const; // c_ab
  };
} // namespace irdm
