#pragma once
// Reference FEM: linear elastodynamics on linear-tetrahedron meshes with P1 or P2 elements,
// consistent mass, Rayleigh damping, Newmark (average acceleration) or generalized-alpha with a
// fixed step and one factorization reused for every step. Units SI.
//
// Time convention: state k is at t_k = k * dt (k = 0..N); the step to state k uses the loads and
// prescribed displacements at t_k. Forces reported for a prescribed displacement are the forces
// the constraint applies to the body at t_k; applying them as vertex loads reproduces the run.
//
// deal.II stays behind the pimpl so that this header is cheap to include.
#include <reference_fem/scene.h>

#include <functional>
#include <map>
#include <memory>
#include <string>
#include <vector>

namespace irdm::fem
{
  class NonlinearElasticity;

  struct SurfaceMesh
  {
    std::vector<long long>               node_tags;   // gmsh node tags
    std::vector<Vec3>                    coordinates; // m, undeformed
    std::vector<std::array<unsigned, 3>> triangles;   // indices into the arrays above, outward
    std::vector<unsigned>                mesh_vertex;      // index in the mesh of each vertex
    std::vector<std::string>             triangle_surface; // physical surface of each triangle
  };

  /// The free part of the assembled linear system, dense: the DoFs of fixed surfaces are
  /// removed. For the modal precompute of impulse responses. Row-major, symmetric.
  struct DenseSystem
  {
    unsigned            n_free = 0;
    std::vector<double> stiffness; // N/m, n_free x n_free
    std::vector<double> mass;      // kg, n_free x n_free (consistent)
    std::vector<int>    vertex_dof_to_free; // [3 * mesh vertex + d] -> free index, -1 if fixed
    // Each free DoF's support point minus the body's centre of mass (m; uniform density), and
    // its axis (0, 1, 2): a linear field's nodal values (P1 and P2 interpolate it exactly).
    std::vector<Vec3>          free_dof_offset;
    std::vector<unsigned char> free_dof_axis;
  };

  /// A truncated modal basis of the fixed system (K phi = w^2 M phi on the free DoFs) at
  /// chosen free DoFs (ElasticDynamics::lowest_modes): the lowest modes, then residual modes
  /// that carry the static compliance the lowest ones miss for loads at the chosen columns.
  struct LowestModes
  {
    unsigned            n_lowest = 0;   // the first n_lowest are exact eigenmodes
    std::vector<double> w2;             // (rad/s)^2, every mode kept (lowest, then residual)
    std::vector<double> shapes;         // rows x modes, row-major; M-orthonormal
    std::vector<double> compliance;     // rows x columns, row-major: (K^-1)(row, column), m/N
    double   largest_residual = 0;      // max over the lowest modes of |K x - w2 M x| / |K x|
    unsigned iterations       = 0;      // block solves of the eigensolver
    // A free body (no fixed surface): its 6 rigid-body modes found and left out of w2/shapes;
    // compliance is then the inertia-relief K^+ (I - M Phi_r Phi_r^T).
    unsigned n_rigid           = 0;
    double   rigid_w2_max      = 0; // largest |w2| of the rigid modes, (rad/s)^2 (round-off)
    double   rigid_shift       = 0; // eps of the factored K + eps M, (rad/s)^2
    unsigned refinement_passes = 0; // inertia-relief refinement passes (most over the blocks)
    double   refinement_change = 0; // the last pass's relative correction (largest)
    // A free body asked for its frame couplings (inertial_modes > 0), as the dense route makes
    // them: every kept mode's centrifugal load (modes x 9, [i][3a + b] = phi_i^T M w_ab) and
    // the inertial couplings of the first n_inertial (9 x n_inertial^2, [3a + b][i][j] =
    // phi_i,a^T M_s phi_j,b); empty otherwise.
    std::vector<double> centrifugal, inertial;
    unsigned            n_inertial = 0;
    // Wall time: seconds_eigen, the lowest modes, holds the factorization of the shifted K
    // and the block Lanczos (of which its block solves); the rest of it is the eigenvectors'
    // purification and check. seconds_static: the residual modes.
    double seconds_eigen = 0, seconds_factor = 0, seconds_lanczos = 0, seconds_solves = 0,
           seconds_static = 0;
  };

  /// The static compliance of a scene's probes at one time (ElasticDynamics::probe_compliance):
  /// S = B K^-1 B^T (m/N), B each probe's spread over its vertices, and the driving-point
  /// stiffness along each probe's direction, d^T S_pp^-1 d (N/m: the force needed per metre
  /// of push when the probe holds all 3 components, as the probes of a scene do).
  struct ProbeCompliance
  {
    std::vector<double>   compliance;   // 3P x 3P, row-major
    std::vector<double>   stiffness;    // per probe, N/m
    std::vector<unsigned> n_vertices;   // per probe: vertices its force spreads over
    std::vector<std::array<double, 3>> point; // per probe: contact point (undeformed), m
    double seconds = 0;                 // factorization and solves
  };

  struct RunResult
  {
    std::vector<double> time;           // s, the output samples
    std::vector<double> kinetic_energy; // J, 1/2 v'Mv
    std::vector<double> strain_energy;  // J, 1/2 u'Ku
    std::map<std::string, std::vector<Vec3>> vertex_displacement; // m, observed vertices
    std::map<std::string, long long>         vertex_node_tag;     // observed and probe vertices
    std::map<std::string, std::vector<Vec3>> probe_displacement;  // m, prescribed vertices
    std::map<std::string, std::vector<Vec3>> probe_force;         // N, on the body
    std::map<std::string, std::vector<Vec3>> probe_contact_point; // m, undeformed (probes)
    std::map<std::string, std::vector<bool>> probe_active;        // in contact (probes)
    std::map<std::string, std::vector<Vec3>> fixed_reaction;      // N, total on each fixed surface
    // Planes (nonlinear: face penalty; linear: vertex contact) and, nonlinear mode, the energy
    // terms besides kinetic and strain.
    std::map<std::string, std::vector<Vec3>>   plane_force;       // N, on the body
    std::map<std::string, std::vector<double>> plane_penetration; // m, deepest surface vertex;
                                                                  // negative: the gap
    std::map<std::string, double> plane_penalty; // Pa/m as used (nonlinear); 0: vertex contact
    std::map<std::string, double> plane_vertex_stiffness; // N/m (linear); 0: rigid
    std::vector<double> contact_energy; // J, penalty energy 1/2 k int pen^2 dA
    std::vector<double> gravity_energy; // J, potential of gravity, -f_g . u
    std::vector<Vec3>   linear_momentum; // N s, sum of M v per axis
    std::vector<Vec3>   center_of_mass_displacement; // m, (1^T M u) / mass per axis (nonlinear)
    // Nonlinear, per sample: how far the body is from small strain. The largest over the
    // quadrature points of the principal stretches' departure from 1, max_i |lambda_i - 1|
    // (the small-strain law: of eps's principal values), and the fraction of the body's
    // volume where that exceeds 0.1. On a P1 mesh the largest is an element's, which at a
    // sharp edge under contact grows as the mesh is refined.
    std::vector<double> largest_strain, strained_volume_fraction;
    unsigned newton_iterations = 0, tangent_factorizations = 0;
    // Nonlinear: the steps of tau at which Newton failed and which were solved again in parts
    // (cut back), and the shortest part used (s; tau when none was cut).
    unsigned cut_steps     = 0;
    double   smallest_step = 0;
    // Nonlinear, J: the largest rise of the total energy (kinetic + strain + contact +
    // gravity) above its start over the samples, and the largest kinetic + strain + contact
    // energy (its scale). With no loads and planes that stand still the total can only fall
    // (damping), so a rise is the integrator's own: average-acceleration Newmark does not keep
    // the energy of large strains at a coarse step (docs/scene-format.md).
    double energy_rise = 0, energy_scale = 0;
    SurfaceMesh                              surface;             // filled if outputs.surface
    std::vector<std::vector<double>>         surface_displacement; // per sample: 3 * n_vertices, m
    std::vector<std::vector<double>>         field_displacement;   // per sample, outputs.field:
                                                                   // [3 v + d] at every mesh vertex, m

    // Cost, s (wall clock).
    double setup_seconds = 0, factorization_seconds = 0, stepping_seconds = 0;
    unsigned n_steps = 0;
  };

  /// Receives the samples a run has recorded so far (up to a batch at a time, and the last
  /// ones at the end); the run clears each batch after the call, so that a long run's memory
  /// stays bounded (see ResultWriter).
  using SampleSink = std::function<void(const RunResult &)>;

  /// Empties the sample series of a result (keeping names, surface and costs).
  void
  clear_samples(RunResult &r);

  /// Samples a run of the scene records: t = 0, every outputs.every steps, and the last step.
  unsigned
  n_samples(const Scene &scene);

  /// Writes a run's outputs (HDF5 and CSV as the scene asks; docs/fem-output.md) as its samples
  /// come: the HDF5 datasets are made at their final size with the first batch and each batch
  /// is appended, CSV rows likewise. Everything goes to part files, and finish() commits them
  /// (every return checked, fsync, rename); destroyed without finish(), it removes them. A
  /// second writer of the same scene name in the same folder is refused (a lock).
  class ResultWriter
  {
  public:
    ResultWriter(const Scene &scene, unsigned n_dofs, unsigned n_samples);
    ~ResultWriter();
    ResultWriter(const ResultWriter &) = delete;
    ResultWriter &
    operator=(const ResultWriter &) = delete;
    /// The samples in batch, after those already written.
    void
    append(const RunResult &batch);
    /// Commits the files; last holds what is known only at the end (penalties, node tags).
    void
    finish(const RunResult &last);

  private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
  };

  class ElasticDynamics
  {
  public:
    /// Reads the mesh, distributes DoFs, assembles K, M, loads and factorizes K_eff.
    explicit ElasticDynamics(const Scene &scene);
    ~ElasticDynamics();
    ElasticDynamics(const ElasticDynamics &) = delete;
    ElasticDynamics &
    operator=(const ElasticDynamics &) = delete;

    /// Runs the scene from its initial state to its duration. The callback, if given, is
    /// called with the fraction done, about every 5 %. With a sink, the samples are handed to
    /// it every `batch` samples and cleared (the result then holds only the last batch).
    RunResult
    run(const std::function<void(double)> &progress = {}, const SampleSink &sink = {},
        unsigned batch = 4096);

    /// Static equilibrium K u = f under the loads at time t (and gravity), with prescribed
    /// displacements at t: one output sample.
    RunResult
    solve_static(double t = 0) const;

    /// Static compliance and driving-point stiffness of the scene's probes at time t (their
    /// contact points and spreads at t; the probes' depths do not matter).
    ProbeCompliance
    probe_compliance(double t = 0) const;

    /// Lowest natural frequencies (Hz) of the undamped, fixed system (subspace iteration).
    std::vector<double>
    natural_frequencies(unsigned n) const;

    /// Writes the scene's outputs (HDF5 and CSV as configured) for a result of this solver.
    void
    write_outputs(const RunResult &result) const;

    /// Dense K and M on the free DoFs (fixed-surface rows and columns removed).
    DenseSystem
    dense_free_system() const;

    /// Free index of each vertex DoF: [3 * mesh vertex + d] -> free index, -1 if fixed (the
    /// numbering of dense_free_system(), without its matrices).
    std::vector<int>
    vertex_dof_to_free() const;

    /// The `count` lowest modes by block Lanczos (block_lanczos.h: shift-invert at 0 with a
    /// MUMPS Cholesky of K; sparse, for models beyond the dense route), augmented by the residual
    /// modes of unit loads at the free DoFs `columns` (the static responses K^-1 e_c with the
    /// lowest modes removed, made K- and M-orthogonal by a small eigenproblem: the basis then
    /// holds K^-1 e_c exactly). With step_shift sigma > 0, also the one-step responses
    /// (K + sigma M)^-1 e_c (then up to two residual modes per column): a time step's
    /// K_eff = a (K + sigma M), so the basis holds the feed-through at the columns exactly
    /// too. Shapes at the free DoFs `rows`, and K^-1 at (rows, columns).
    /// A free body (nothing fixed): the shift-invert targets -eps, the six rigid-body modes
    /// (w2 = 0) are found and left out, every other vector is M-orthogonal to them, and K^-1
    /// becomes the inertia-relief K^+ (I - M Phi_r Phi_r^T) (sparse_modes.cc); with
    /// inertial_modes > 0, its frame couplings too (LowestModes::centrifugal, inertial).
    /// Serial (MPI_COMM_SELF).
    LowestModes
    lowest_modes(unsigned count, const std::vector<int> &rows, const std::vector<int> &columns,
                 double step_shift = 0, unsigned inertial_modes = 0,
                 double tolerance = 1e-10) const;

    /// All boundary triangles with their surface names; vertices in mesh order.
    SurfaceMesh
    boundary() const;

    unsigned
    n_dofs() const;
    /// DoFs not fixed by a constraint (what dense_free_system() would hold).
    unsigned
    n_free_dofs() const;
    unsigned
    n_cells() const;
    double
    volume() const; // m^3, sum of cell measures
    const Scene &
    scene() const;

  private:
    class Impl;
    std::unique_ptr<Impl> impl_;
    friend class NonlinearElasticity; // builds on the same discretization (Impl)
  };
} // namespace irdm::fem
