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
// FEM's symmetric part is), a backtracking line search on the residual norm. The body's part
// of the tangent (inertia, elasticity, damping: O(elements r^2), the step's dominant cost) is
// kept from step to step and evaluated again only where an iteration reduces the residual by
// less than a set ratio (a modified Newton method); the planes' part (O(contacts r^2)) is
// fresh at every iterate. It converges to the same stop either way. A step where
// Newton does not converge is solved again in 2, 4, 8, 16 parts, as the FEM cuts back
// (cut_steps()); if even 16 parts do not converge, their best iterates are taken and the step
// counted (failed_steps()): a step is always taken. Allocation-free after construction.
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
  /// (N, model frame): the FEM's load at t_{n+1}, taken at the alpha level with the previous
  /// step's.
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
    // Newton's stop: the residual's norm at most this fraction of the largest force in it
    // (the nonlinear FEM's), or an update of round-off size.
    double tolerance = 1e-8;
  };

  class ReducedNonlinearBody
  {
  public:
    static constexpr int max_planes = 8, max_probes = 4;

    /// Gathers the cubature elements' and the surface's rows of the basis (allocates).
    explicit ReducedNonlinearBody(const ReducedNonlinearModel &model,
                                  const ReducedBodyOptions    &options = {});

    /// One step of tau with the planes where they are at its end, and the vertex forces at
    /// its end. Returns true if Newton converged; false if it did not (the step is still
    /// taken, counted in failed_steps()) or if the input is out of range (no step taken).
    bool
    step(const ReducedPlane *planes, int n, const ReducedVertexForce *forces = nullptr,
         int n_forces = 0, const ReducedProbe *probes = nullptr, int n_probes = 0);

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
    /// planes' contacts in it; a probe's coupling too if the step had one). False (nothing
    /// written) for a bad patch or before the first factorization at the model's step.
    /// Allocates nothing.
    bool
    point_state(const unsigned *vertices, const double *weights, int n, double u[3],
                double v[3], double a[3], double W[9]);

    /// Force of plane a on the body after the latest step (N, model frame), and how many
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
    /// Surface displacement after the latest step, 3 per surface vertex (m, model frame).
    void
    surface_displacement(double *u) const;
    const Eigen::VectorXd &
    coordinates() const
    {
      return q_;
    }
    /// Kinetic (1/2 v^T v: U is M-orthonormal) and strain energy (J) of the latest state.
    double
    energy() const;
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
    /// Evaluations of the body's tangent so far (each O(elements r^2)).
    unsigned long
    tangent_evaluations() const
    {
      return tangent_evaluations_;
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
    // The cubature elements' rows of U as columns of U^T (12 per element, one after another:
    // each element's block contiguous), each element's tetrahedron and weight.
    Matrix                            element_basis_;
    std::vector<elastic::Tetrahedron> element_;
    std::vector<double>               weight_;
    // Per surface vertex with a free DoF: U_s (3 x r, rows of fixed DoFs zero), X_s, area.
    std::vector<Eigen::Matrix<double, 3, Eigen::Dynamic>> surface_basis_;
    std::vector<Eigen::Vector3d>                          surface_rest_;
    std::vector<double>                                   surface_area_;
    std::vector<unsigned>                                 surface_index_; // into the model's
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
    unsigned long tangent_evaluations_ = 0;
    Eigen::Matrix<double, Eigen::Dynamic, 12> KU_; // an element's U_e^T w_e K_e
    Eigen::LDLT<Matrix> solver_;
    std::array<std::array<double, 3>, max_planes> plane_force_{}, trial_force_{};
    std::array<int, max_planes>                   plane_vertices_{}, trial_vertices_{};
    unsigned      last_iterations_ = 0;
    unsigned long failed_steps_ = 0, inverted_ = 0;

    // The vertex forces' reduced load into g. False for a vertex out of range or a force
    // that is not finite (g then partial).
    bool
    vertex_load(const ReducedVertexForce *forces, int n, Vector &g) const;
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
