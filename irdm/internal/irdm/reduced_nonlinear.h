#pragma once
// A reduced nonlinear model at run time (issue 50; docs/reduced-model.md): the neo-Hookean
// FEM's law on a small mass-orthonormal basis U (u = U q at every mesh vertex), its internal
// force and tangent summed over a cubature (a few elements with non-negative weights; every
// element with weight 1 in a file without one), the FEM's integrator in reduced coordinates,
// and rigid planes by the FEM's own node-based penalty at the surface vertices.
//
// One step of tau solves, in q at the step's end (generalized-alpha, the FEM's coefficients;
// Newmark when alpha_m = alpha_f = 0):
//   (1 - am) a_1 + am a_0 + alpha v_af + g(q_af) + beta g_d(q_af, v_af)
//     = (1 - af) g_c(q_1, t_1) + af g_c(q_0, t_0),
// with g = sum_e w_e U_e^T f_e(U_e q) the reduced internal force, g_d the objective damping
// force the same way, g_c = U^T f_c the planes' penalty force, and a_1, v_1 Newmark's in q_1.
// Newton's method with the reduced tangent (the damping's dependence on q left out, as the
// FEM's symmetric part is), a backtracking line search on the residual norm (where it finds no
// decrease: the tangent made fresh, then a full step, but never two running that raise the
// residual, and a residual that is not finite never converged). The body's part
// of the tangent (inertia, elasticity, damping: U^T K U, O(vertices r^2), the step's dominant cost) is
// kept from step to step and evaluated again only where an iteration reduces the residual by
// less than a set ratio (a modified Newton method); the planes' part (O(contacts r^2)) is
// fresh at every iterate. It converges to the same stop either way. A step where
// Newton does not converge is solved again in 2, 4, 8, 16 parts, as the FEM cuts back
// (cut_steps()); if even 16 parts do not converge, their best iterates are taken and the step
// counted (failed_steps()): a step is always taken. Allocation-free after construction.
//
// A free body (six rigid modes first in its basis) moves in a floating frame by default
// (docs/reduced-model.md, "A free body"): each step is solved in the inertial frame where the
// body frame stands at the step's start, in which the step's own turn is small and its
// linearized rotation strains the body by its square only; at the step's end the frame is
// moved onto the body (its rigid coordinates, U_r^T M u, made zero: the linearized Tisserand
// frame of docs/free-body.md) and the state is carried into it exactly: u' = Q (X~ + u - t)
// - X~, velocity and acceleration turned by Q, projected on the basis by the nine blocks
// J_ab = U_a^T M_s U_b. The frame's turn is exact, so the body's strain does not grow with
// it; every inertial force of the moving frame follows from the carried state.
#include <irdm/element_lanes.h>
#include <irdm_common/neo_hookean_tet.h>

#include <Eigen/Dense>

#include <array>
#include <string>
#include <vector>

namespace irdm
{
  struct ReducedNonlinearModel
  {
    std::string path;
    double      time_step = 0;                                   // s
    double      alpha_m = 0, alpha_f = 0, gamma = 0.5, beta = 0.25; // integrator
    double      rayleigh_alpha = 0, rayleigh_beta = 0;           // 1/s, s
    double      mu = 0, lambda = 0;                              // Pa
    double      default_penalty = 0;                             // Pa/m
    unsigned    size = 0;                                        // r
    unsigned    n_vertices = 0;
    std::vector<double> basis; // [3 v + d][k], m per unit of q
    std::vector<std::array<unsigned, 4>> tetrahedra;
    std::vector<elastic::Tetrahedron>    elements;
    // The cubature: elements and their weights (every element with weight 1 when the file
    // has none: `every_element`).
    std::vector<unsigned> cubature_elements;
    std::vector<double>   cubature_weights;
    bool                  every_element = true;
    double                cubature_training_error = 0; // relative, as trained (0: none)
    // The surface: each vertex's mesh vertex, node tag, position (m), outward triangles,
    // lumped area (m^2, the FEM's penalty weight) and which of its three DoFs are free.
    std::vector<unsigned>                surface_vertex;
    std::vector<long long>               node_tags;
    std::vector<std::array<double, 3>>   coordinates;
    std::vector<std::array<unsigned, 3>> triangles;
    std::vector<double>                  lumped_area;
    std::vector<std::array<bool, 3>>     free_dof;
    unsigned lowest_modes = 0, residual_modes = 0, modal_derivatives = 0;
    // A free body's six rigid modes, the basis's first columns (0: grounded). rigid_loads
    // (r x 6, row-major; empty in a version 1 file): U^T M w for the unit rigid velocity
    // fields w (translations along x, y, z, rotations about x, y, z through the centre of
    // mass), so a uniform acceleration g loads q by the first three columns times g, and a
    // rigid velocity (v, w) is q' = the columns times (v, w) where the basis holds it.
    unsigned              rigid_modes = 0;
    // A free body's six uniform strain fields in the basis (attribute uniform_strain_fields):
    // with the rigid modes they hold every finite rotation of the body, which the floating
    // frame needs (0 in a file made before them).
    unsigned              uniform_strain_fields = 0;
    std::vector<double>   rigid_loads;
    double                mass = 0;                 // kg
    std::array<double, 3> center_of_mass{0, 0, 0}; // m, undeformed
    std::string mesh_hash;
  };

  /// InputError for a missing or bad file (docs/model-format.md), or a time step other than
  /// expected_time_step (> 0).
  ReducedNonlinearModel
  load_reduced_nonlinear_model(const std::string &path, double expected_time_step = 0);

  /// A rigid frictionless plane for one step: normal (unit, toward the body), a point of it
  /// at the step's end (m, model frame), and the penalty (Pa/m times each vertex's lumped
  /// area; 0: the model's default) or a stiffness per vertex.
  struct ReducedPlane
  {
    std::array<double, 3> normal{0, 0, 1}, point{0, 0, 0};
    double                penalty   = 0;
    double                stiffness = 0; // N/m per vertex (> 0: instead of the penalty)
  };

  /// A known force on a surface vertex (index into the model's surface) at the end of a step
  /// (N, world frame: the model frame for a grounded body): the FEM's load at t_{n+1}, taken
  /// at the alpha level with the previous step's.
  struct ReducedVertexForce
  {
    unsigned              vertex = 0;
    std::array<double, 3> force{};
  };

  /// A virtual coupling (Colgate et al. 1995) to a point of the surface (a patch of surface
  /// vertices with weights summing to 1): a spring and a damper between the device and the
  /// point, solved implicitly with the body in the step, as the planes are. The force on the
  /// body is k (d - u_p) + b (d' - u_p') at the step's end; unilateral: none where it would
  /// pull against `direction`.
  struct ReducedProbe
  {
    static constexpr int max_patch = 256;
    int                             n_patch = 0;
    std::array<unsigned, max_patch> vertices{}; // into the model's surface
    std::array<double, max_patch>   weights{};
    std::array<double, 3>           target{};          // m: the device's displacement, step's end
    std::array<double, 3>           target_velocity{}; // m/s
    double                          stiffness = 0, damping = 0; // N/m (> 0), N s/m
    std::array<double, 3>           direction{0, 0, -1};        // unit push direction
    bool                            unilateral = false;
  };

  struct ReducedBodyOptions
  {
    // Keep the body's tangent while Newton contracts: an iteration that leaves more than
    // this ratio of the residual evaluates it again at the new iterate. false: every
    // iteration evaluates it (Newton's method proper).
    bool   reuse_tangent         = true;
    double tangent_refresh_ratio = 0.1;
    // With the kept tangent: where an iteration contracts slowly, the tangent is not made
    // inside that step but over the next tangent_steps steps, a piece a step (the elements'
    // stiffness, then U^T (K U) by ranges of the cubature's vertex rows), at the state where
    // the slow step ended, and taken from the step after its last piece. The slow step and
    // those in between go on with the tangent they have (the residual decides the root, the
    // tangent only how fast Newton gets there), so a slow step no longer makes a whole one.
    // Still made at once: where the line search finds no decrease with it, past half a
    // step's iteration limit, for a step or part of another length, and where an iteration
    // leaves more than tangent_at_once_ratio of the residual (below 1: where the kept tangent
    // steers poorly; 1, the default: only where an iteration raised it, the full step taken
    // past a failed line search, which keeps the slowest step lowest where the tangent goes
    // stale fast). 0: made at once in the step that asks.
    unsigned tangent_steps         = 0;
    double   tangent_at_once_ratio = 1;
    // Keep the planes' and probes' tangent while their contacts (a probe's patch rows and
    // coupling weight) stay, and the factorization of the step's tangent while neither the
    // body's tangent nor that contact tangent change (the same matrices: the same steps, bit
    // for bit). false: the contact tangent made at every residual and the factorization at
    // every iteration.
    bool keep_factorization = true;
    // U's rows at the cubature's and the surface's vertices rounded to float, and read in
    // single precision with the sums in double (half the bytes a residual streams): the
    // elastic, damping and plane forces are then the Galerkin projection on U so rounded
    // (relative 6e-8; the inertia, loads and probes keep U's own). The body's tangent
    // U^T (K U) is formed in float arithmetic on those rows (float sums: Newton converges to
    // the residual's root all the same). false: U's own rows and a tangent in
    // double.
    bool single_precision_rows = true;
    // Newton's stop: the residual's norm at most this fraction of the largest force in it
    // (the nonlinear FEM's), or an update of round-off size.
    double tolerance = 1e-8;
    // A free body's model moves in a floating frame (above); false: in one frame for the
    // whole run, its rotations linearized (a turn of theta strains it by about theta^2 / 2).
    bool floating_frame = true;
    // A floating body's projected forces with their true torque. On a basis that does not
    // hold e x (U q), A U^T f (A the angular momentum's 3 x r map) is not the torque of f: the
    // projected internal force has a torque of its own (the objective law's full force has
    // none) and the planes' projected force a torque other than theirs at the deformed
    // vertices, so a body at rest on a frictionless floor spins up about the vertical. On: a
    // torque on the body as a whole, a rigid rotation's load C w (C = U^T M (e_k x X~)), makes
    // A (g - g_c - C w) = -tau_c at each time level of the step (about 12 r^2 multiply-adds a
    // residual; the tangent leaves it out). The vertex forces keep their projected torque, and
    // the carry its projection of the turned state. Nothing changes where the basis holds
    // every mode. false: the Galerkin projection's own
    // torques (to measure what they leak).
    bool keep_angular_momentum = true;
  };

  class ReducedNonlinearBody
  {
  public:
    static constexpr int max_planes = 8, max_probes = 4;

    /// Gathers the cubature elements' and the surface's rows of the basis (allocates); for a
    /// floating frame, the blocks J_ab from the mesh's consistent mass at the model's uniform
    /// density (mass_kg over the volume). InputError if the basis is not orthonormal in that
    /// mass, its elastic fields are not orthogonal to its rigid ones, or it lacks the uniform
    /// strain fields.
    explicit ReducedNonlinearBody(const ReducedNonlinearModel &model,
                                  const ReducedBodyOptions    &options = {});

    /// One step of tau with the planes where they are at its end, and the vertex forces at
    /// its end (both in the world frame, the model frame at the start). Returns true if Newton
    /// converged; false if it did not (the step is still taken, counted in failed_steps()) or
    /// if the input is out of range (no step taken). A body in a floating frame takes no
    /// probes (their targets are displacements in the model frame).
    bool
    step(const ReducedPlane *planes, int n, const ReducedVertexForce *forces = nullptr,
         int n_forces = 0, const ReducedProbe *probes = nullptr, int n_probes = 0);

    /// The body's tangent at the latest state for a step of the model's length, made now (a
    /// real-time loop calls it before it starts, so that its first step does not make one).
    /// Counted in tangent_evaluations(). Allocates nothing.
    void
    prepare_tangent();

    /// Before the first step: a uniform acceleration field on the body from now on (m/s^2,
    /// model frame; gravity, the reduced load U^T M (1 (x) g)), the vertex forces at t = 0
    /// (those a step's forces start from), and, for a free body's model (its basis holding
    /// the rigid modes), a rigid start velocity v + w x (X - c) (m/s, rad/s). The
    /// acceleration at the start is the balance's there, as the FEM's start from rest, with
    /// no plane touching yet: a rigid velocity strains nothing, so a = (gravity's and the
    /// forces' reduced load) - alpha q'. False (nothing set) after a step, for a model
    /// without rigid_loads (a version 1 file), for a velocity on a grounded model, or for a
    /// bad vertex or a value that is not finite.
    bool
    start(const std::array<double, 3> &gravity, const std::array<double, 3> &velocity = {},
          const std::array<double, 3> &spin = {}, const ReducedVertexForce *forces = nullptr,
          int n_forces = 0);

    /// Force of probe p's coupling on the body after the latest step (N), and the probed
    /// point's displacement (m).
    const std::array<double, 3> &
    probe_force(int p) const
    {
      return probe_force_[p];
    }
    std::array<double, 3>
    probe_displacement(int p) const;

    /// What a force loop needs of the latest state at a point (a patch of surface vertices
    /// and weights, as a probe's): its displacement u (m), velocity v (m/s) and acceleration
    /// a (m/s^2), and its
    /// compliance over one step, W = (1 - af) U_p T^-1 U_p^T (m/N, row-major 3 x 3): the
    /// change of the point's displacement at the next step's end per unit change of a force
    /// held on it over that step, T the step's tangent as Newton last factorized it (the
    /// planes' contacts in it; a probe's coupling too if the step had one; a body's tangent
    /// made since, over steps, only once a step has iterated with it). False (nothing
    /// written) for a bad patch, before the first factorization at the model's step, or for a
    /// body in a floating frame (its state is the frame's).
    /// Allocates nothing.
    bool
    point_state(const unsigned *vertices, const double *weights, int n, double u[3],
                double v[3], double a[3], double W[9]);

    /// Force of plane a on the body after the latest step (N, world frame), and how many
    /// surface vertices it pushes.
    const std::array<double, 3> &
    plane_force(int a) const
    {
      return plane_force_[a];
    }
    int
    plane_vertices(int a) const
    {
      return plane_vertices_[a];
    }
    /// Surface displacement after the latest step, 3 per surface vertex (m): the world
    /// position less the rest position (the frame's motion included).
    void
    surface_displacement(double *u) const;
    /// The centre of mass after the latest step (m, world frame).
    Eigen::Vector3d
    center_of_mass() const;
    /// A floating body's angular momentum about its centre of mass after the latest step
    /// (kg m^2/s, world frame), in the P1 consistent mass: the frame's spin and the
    /// deformation's own, sum_ab eps_kab (X~ + U q)_a^T M_s (U v)_b. NaN for a body without a
    /// floating frame. O(r^2).
    Eigen::Vector3d
    angular_momentum() const;
    /// A floating body's torque of the planes' and the vertex forces about its centre of mass
    /// at the latest step's end (N m, world frame): with angular_momentum(), a reduced model's
    /// balance of angular momentum (a basis that does not hold e x (U q) lets the projected
    /// forces turn the body too: the vertex forces always, the internal force and the planes'
    /// with keep_angular_momentum off). Zero for a body without a floating frame.
    const Eigen::Vector3d &
    external_torque() const
    {
      return torque_;
    }
    /// The floating frame: where the model's undeformed centre of mass is (m, world) and its
    /// turn (model frame to world); the model's own position and the identity without one.
    const Eigen::Vector3d &
    frame_origin() const
    {
      return frame_origin_;
    }
    const Eigen::Matrix3d &
    frame_rotation() const
    {
      return frame_rotation_;
    }
    bool
    floating() const
    {
      return floating_;
    }
    const Eigen::VectorXd &
    coordinates() const
    {
      return q_;
    }
    /// Kinetic (1/2 v^T v: U is M-orthonormal) and strain energy (J) of the latest state.
    double
    energy() const;
    double
    strain_energy() const
    {
      return strain_energy(q_);
    }
    unsigned
    newton_iterations() const // over the latest step
    {
      return last_iterations_;
    }
    unsigned long
    failed_steps() const
    {
      return failed_steps_;
    }
    /// Steps where Newton failed at tau and which were solved again in 2, 4, ... 16 parts
    /// (the planes and forces linear over the step), as the FEM cuts back.
    unsigned long
    cut_steps() const
    {
      return cut_steps_;
    }
    /// Evaluations of the body's tangent made at once so far (each O(vertices r^2)): inside a
    /// step, or by prepare_tangent().
    unsigned long
    tangent_evaluations() const
    {
      return tangent_evaluations_;
    }
    /// Evaluations of the body's tangent made over steps (tangent_steps) and taken into use.
    unsigned long
    staged_tangent_evaluations() const
    {
      return staged_tangents_;
    }
    /// The body's tangent in use (r x r, its lower triangle; the inertia's, damping's and
    /// internal force's rates in q at the step's length).
    const Eigen::MatrixXd &
    body_tangent() const
    {
      return body_tangent_;
    }
    /// Factorizations of the step's tangent so far (each O(r^3)); one is kept while neither
    /// the body's tangent nor the planes' contacts change.
    unsigned long
    factorizations() const
    {
      return factorizations_;
    }
    unsigned long
    inverted_evaluations() const // residuals refused because a cubature element inverted
    {
      return inverted_;
    }
    const ReducedNonlinearModel &
    model() const
    {
      return m_;
    }

  private:
    using Matrix = Eigen::MatrixXd;
    using Vector = Eigen::VectorXd;
    const ReducedNonlinearModel &m_;
    ReducedBodyOptions           options_;
    unsigned                     r_ = 0;
    // The cubature elements' distinct vertices: their rows of U (three per vertex, row-major:
    // a vertex's 3 x r block contiguous), each element's four vertices among them, its
    // tetrahedron and weight. A residual takes every vertex's displacement and gives back
    // their forces by one pass over the rows each, O(vertices r) whatever the elements, which
    // share vertices.
    using RowMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
    RowMatrix                             vertex_basis_;
    Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> vertex_rows_; // rounded, where the option says
    std::vector<std::array<unsigned, 4>>  element_vertices_;
    std::vector<elastic::Tetrahedron>     element_;
    std::vector<double>                   weight_;
    std::vector<detail::ElementLanes>     element_lanes_; // the same, four a group (element_forces.h)
    Vector vertex_u_, vertex_v_, vertex_f_; // 3 per cubature vertex: displacement, velocity, force
    // q_af and v_af are linear in the iterate x, so a residual takes one product over the
    // rows, U x (vertex_x_), and the part's start gives the rest: U q_af = (1 - af) U x + af U q
    // and U v_af = c (U x - U q) + U w, c = (1 - af) gamma / (beta h), w the v_af of x = q
    // (vertex_q_, vertex_w_; part_start_rows()).
    Vector vertex_x_, vertex_q_, vertex_w_, w_;
    std::vector<unsigned> vertex_local_; // per mesh vertex: its cubature vertex, or ~0u
    // The body's tangent as U^T (K U): K the weighted elements' stiffness assembled by vertex
    // pair (3 x 3 blocks, rows of a block CSR; each element's 16 blocks' places), then K U and
    // U^T (K U). In double: K U into KU_ (3 per vertex x r) a vertex's rows (KU_row_) at a
    // time, U^T (K U) in slices of slice_ rows (Eigen's product then keeps its work space on
    // the stack: nothing allocated). In float where the rows are (single_precision_rows): K U
    // into KU_rows_, U^T (K U)'s lower triangle into tangent_rows_ (tangent_product.h).
    std::vector<unsigned>                 block_row_start_, block_column_;
    std::vector<std::array<unsigned, 16>> element_blocks_;
    std::vector<Eigen::Matrix3d>          stiffness_blocks_;
    RowMatrix                             KU_;
    Eigen::Matrix<double, 3, Eigen::Dynamic, Eigen::RowMajor>             KU_row_;
    Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> KU_rows_, tangent_rows_;
    Eigen::Index                          slice_ = 3;
    // Per surface vertex with a free DoF: U_s (its 3 rows of surface_basis_, rows of fixed
    // DoFs zero), X_s, area; every one's displacement at the latest residual's iterate. A
    // vertex whose rows are a cubature vertex's own, bit for bit, takes its displacement from
    // vertex_x_ (surface_shared_: surface vertex, cubature vertex); the others' rows
    // (surface_other_, compact in surface_other_basis_ and, in float, surface_other_rows_)
    // take one product a residual, whatever the planes.
    RowMatrix                    surface_basis_;
    std::vector<std::array<unsigned, 2>> surface_shared_;
    std::vector<unsigned>        surface_other_;
    RowMatrix                    surface_other_basis_;
    Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> surface_other_rows_;
    Vector                       surface_other_u_;
    std::vector<Eigen::Vector3d> surface_rest_;
    std::vector<double>          surface_area_;
    std::vector<unsigned>        surface_index_; // into the model's
    Vector                       surface_u_;
    Vector q_, v_, a_;          // state at the latest step
    Vector g_c_;                // reduced plane force of the latest step
    Vector g_f_, g_f_new_;      // reduced vertex forces of the latest step and of this one
    Vector g_f_end_;            // of this step's end (g_f_new_ is its part's)
    Vector body_force_;         // the uniform acceleration's reduced load (start())
    bool   stepped_ = false;    // a step has been taken
    Vector q0_, v0_, a0_, g_c0_, g_f0_; // the step's start, for a step cut into parts
    double h_ = 0;              // the length of the step or part being solved
    static constexpr unsigned max_parts = 16;
    std::array<ReducedPlane, max_planes> part_planes_{}, last_planes_{};
    int                                  last_n_ = 0;
    // The step's probes, each one's U_p (3 x r), its target at the part's end, and its force.
    std::array<ReducedProbe, max_probes>                          probes_{};
    int                                                           n_probes_ = 0;
    std::array<Eigen::Matrix<double, 3, Eigen::Dynamic>, max_probes> probe_basis_;
    std::array<std::array<double, 3>, max_probes> last_target_{}, part_target_{};
    std::array<bool, max_probes>                  last_target_known_{};
    std::array<std::array<double, 3>, max_probes> probe_force_{}, probe_trial_force_{};
    Eigen::Matrix<double, 3, Eigen::Dynamic>      point_basis_; // point_state's U_p
    Matrix                                        point_solve_; // T^-1 U_p^T
    double                                        factorized_h_ = 0; // solver_'s step length
    unsigned long                        cut_steps_ = 0;
    // The step being solved.
    Vector x_, a1_, v1_, q_af_, v_af_, residual_, trial_, r_trial_, dq_, g_c_trial_, best_;
    Vector g_int_, Un_;  // the reduced internal and damping force; U_s^T n
    double scale_ = 0;   // the residual's force scale (its largest part), for convergence
    // The tangent: the body's part (lower triangle; valid for the step length it was made
    // with), the planes' part, and their sum as factorized.
    Matrix body_tangent_, contact_tangent_, tangent_;
    double body_tangent_h_ = 0; // 0: none yet
    // A tangent made over steps (tangent_steps): asked for by the step being solved, to be
    // staged at the next step's start, in the making (its state U q and U w at the cubature's
    // vertices, the next piece: the elements' ranges, then the block rows'), the sum so far
    // (lower triangle; swapped with body_tangent_ when done).
    bool          tangent_wanted_ = false, stage_at_start_ = false, staging_ = false;
    unsigned      staged_piece_   = 0;
    Vector        staged_u_, staged_v_;
    Matrix        staged_tangent_;
    unsigned long staged_tangents_ = 0;
    unsigned long tangent_evaluations_ = 0, factorizations_ = 0;
    // Changes whenever body_tangent_ or contact_tangent_ does; solver_ holds the one of
    // factorized_version_.
    unsigned long tangent_version_ = 1, factorized_version_ = 0;
    Eigen::LDLT<Matrix> solver_;
    std::array<std::array<double, 3>, max_planes> plane_force_{}, trial_force_{};
    std::array<int, max_planes>                   plane_vertices_{}, trial_vertices_{};
    unsigned      last_iterations_ = 0;
    unsigned long failed_steps_ = 0, inverted_ = 0;

    // The floating frame (a free body's; docs/reduced-model.md). R maps the body frame to the
    // world; the body frame's point c0 (the undeformed centre of mass) is at frame_origin_.
    bool            floating_ = false;
    Eigen::Matrix3d frame_rotation_ = Eigen::Matrix3d::Identity();
    Eigen::Vector3d frame_origin_   = Eigen::Vector3d::Zero(), center0_ = Eigen::Vector3d::Zero();
    Eigen::Vector3d gravity_        = Eigen::Vector3d::Zero(); // world, m/s^2
    double          size_           = 0; // the body's largest surface distance from c0 (m)
    std::array<Matrix, 9> J_;           // U_a^T M_s U_b, block 3a + b
    Eigen::Matrix<double, Eigen::Dynamic, 3> translation_loads_; // U^T M 1_a
    Eigen::Matrix<double, Eigen::Dynamic, 9> turned_rotation_;   // (U^T M [e_j]x U) c_i, col 3i + j
    Eigen::Matrix<double, Eigen::Dynamic, 3> rotation_loads_;    // c_i = U^T M (e_i x X~)
    Eigen::Matrix<double, 6, 6> rigid_inverse_;                  // (U_r^T M W)^-1
    // A^T, L = A q' about the centre of mass (angular_momentum_map), and its work vector.
    mutable Eigen::Matrix<double, Eigen::Dynamic, 3> momentum_map_;
    mutable Vector                                   momentum_work_;
    Matrix P_;                                                   // sum_ab Q_ab J_ab
    Vector carried_;
    // The planes' penalty forces of the latest residual, per contact (surface_basis_ index and
    // force, body frame), to carry the step's end force into the next frame.
    std::vector<unsigned>        contact_vertex_;
    std::vector<Eigen::Vector3d> contact_force_;
    size_t                       n_contacts_ = 0;
    // Each contact's plane and its tangent's weight (1 - af) k A; and the contacts that made
    // contact_tangent_ (contact_tangent()), which is kept while they stay.
    std::vector<int>                   contact_plane_;
    std::vector<double>                contact_weight_;
    std::vector<unsigned>              key_vertex_;
    std::vector<double>                key_weight_;
    std::vector<std::array<double, 3>> key_normal_;
    size_t                             key_contacts_      = 0;
    bool                               contact_key_valid_ = false;
    std::array<bool, max_probes>       probe_active_{};
    // Each probe's coupling weight in the tangent (0: inactive), and the probes that made
    // contact_tangent_: their weights and U_p.
    std::array<double, max_probes>     probe_weight_{}, key_probe_weight_{};
    std::array<Eigen::Matrix<double, 3, Eigen::Dynamic>, max_probes> key_probe_basis_;
    int                                key_probes_ = 0;
    Eigen::Vector3d              torque_ = Eigen::Vector3d::Zero(); // external_torque()
    // The planes' torque about the centre of mass (the step's frame), and what the projected
    // force's torque A U^T f misses of it (keep_angular_momentum): at the latest residual, at
    // the step's start (carried into its frame) and at a cut step's start.
    Eigen::Vector3d contact_torque_trial_ = Eigen::Vector3d::Zero();
    Eigen::Vector3d contact_leak_trial_ = Eigen::Vector3d::Zero(), contact_leak_ = Eigen::Vector3d::Zero(),
                    contact_leak0_ = Eigen::Vector3d::Zero();

    // The external forces' torque about the centre of mass at the step's end, before the
    // carry (the step frame's contacts and vertex forces), into torque_.
    void
    sum_external_torque(const ReducedVertexForce *forces, int n_forces);

    // U's row at mesh vertex v, DoF d (1 x r).
    Eigen::Map<const Eigen::RowVectorXd>
    basis_row(unsigned v, int d) const;
    // U_s of surface_basis_'s vertex s (3 x r).
    auto
    surface_rows(size_t s) const
    {
      return surface_basis_.middleRows<3>(3 * Eigen::Index(s));
    }
    // The cubature's vertices, their rows of U and the block pattern of their stiffness
    // (constructor).
    void
    prepare_cubature();
    // The blocks J_ab and the rigid loads the frame needs (constructor).
    void
    prepare_frame();
    // A^T at q, the angular momentum about the centre of mass L = A q' in the frame, into
    // momentum_map_: column k = c_k + (J_ba - J_ab) q - T (e_k x d), (a, b) = (k + 1, k + 2),
    // T = U^T M 1 and d = T^T q / m the centre's shift from c0 (so T^T A^T = 0: a force along
    // A^T moves no momentum).
    void
    angular_momentum_map(const Vector &q) const;
    // Moves the frame onto the body at a step's end and carries the state into it; the
    // step's end vertex forces (world) give its force in the new frame.
    void
    carry_into_new_frame(const ReducedVertexForce *forces, int n_forces);
    // Planes of the world in the body frame of the step.
    void
    planes_to_body(ReducedPlane *planes, int n) const;

    // The vertex forces' reduced load into g. False for a vertex out of range or a force
    // that is not finite (g then partial).
    bool
    vertex_load(const ReducedVertexForce *forces, int n, Vector &g,
                const Eigen::Matrix3d &to_body = Eigen::Matrix3d::Identity()) const;
    // U_p of a patch into B (its fixed DoFs' rows zero). False for a bad patch.
    bool
    patch_basis(const unsigned *vertices, const double *weights, int n,
                Eigen::Matrix<double, 3, Eigen::Dynamic> &B) const;
    // The step's residual at q_1 = x, with the body's tangent into T (lower triangle) and the
    // planes' into C where they are given; the planes' force into g_c, plane_force,
    // vertices. False if a cubature element inverted.
    bool
    residual(const Vector &x, const ReducedPlane *planes, int n, Vector &res, Matrix *T,
             Matrix *C, Vector &g_c, std::array<std::array<double, 3>, max_planes> &force,
             std::array<int, max_planes> &vertices);
    // The planes' and probes' tangent of the latest residual's contacts into C (lower
    // triangle), made again only where those contacts changed (tangent_version_ then moves).
    void
    contact_tangent(const ReducedPlane *planes, Matrix &C);
    // U q and U w at the part's start (vertex_q_, vertex_w_), from q_, v_, a_ and h_.
    void
    part_start_rows();
    // The cubature's internal force (elastic and damping) at the iterate x (q_af, v_af) into
    // g_int_, and its tangent (times 1 - af, the damping's by c_c) added to T's lower
    // triangle where given; U x into vertex_x_. False if an element inverted.
    bool
    internal_force(const Vector &x, Matrix *T, double af, double c_c);
    // The tangent's parts (reduced_tangent.cc). The weighted stiffness of elements [e0, e1)
    // at the cubature vertices' displacement u and velocity v (the latter read where damped)
    // added to stiffness_blocks_ (cleared where e0 = 0), times 1 - af, the damping's by c_c.
    void
    element_stiffness(const Vector &u, const Vector &v, double af, double c_c, size_t e0, size_t e1);
    // U^T (K U) over block rows [i0, i1): K U's rows, then their share of U^T (K U) summed
    // into T's lower triangle (in double) or into tangent_rows_ (in float; cleared by
    // begin_tangent_sum(), added to T by end_tangent_sum()).
    void
    tangent_rows(size_t i0, size_t i1, Matrix &T);
    void
    begin_tangent_sum();
    void
    end_tangent_sum(Matrix &T);
    // The tangent made over steps: staged at a step's start (stage_tangent(), after
    // part_start_rows()), then one piece of `pieces` (true when it is done and in use).
    void
    stage_tangent();
    bool
    tangent_piece(unsigned pieces);
    // At a step's end: the next piece, or a new tangent staged where the step asked for one.
    void
    advance_staged_tangent();
    // The residual at x_ into residual_, its planes' tangent, and the body's tangent where
    // `body` (counted). False if an element inverted.
    bool
    evaluate(const ReducedPlane *planes, int n, bool body);
    double
    strain_energy(const Vector &q) const;
    // Newton's method for one step or part of length h_ from the state (q_, v_, a_) with the
    // forces g_f_new_ at its end; sets the state at its end. False if it did not converge
    // (the best iterate is taken).
    bool
    solve(const ReducedPlane *planes, int n);
  };
} // namespace irdm
