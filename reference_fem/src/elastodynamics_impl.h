#pragma once
// Internal: the deal.II side of ElasticDynamics, shared by its translation units.
#include <deal.II/base/quadrature_lib.h>
#include <deal.II/dofs/dof_handler.h>
#include <deal.II/fe/fe_simplex_p.h>
#include <deal.II/fe/fe_system.h>
#include <deal.II/fe/mapping_fe.h>
#include <deal.II/grid/tria.h>
#include <deal.II/lac/affine_constraints.h>
#include <deal.II/lac/full_matrix.h>
#include <deal.II/lac/petsc_solver.h>
#include <deal.II/lac/petsc_sparse_matrix.h>
#include <deal.II/lac/petsc_vector.h>
#include <deal.II/lac/solver_control.h>
#include <deal.II/lac/sparse_matrix.h>
#include <deal.II/lac/sparsity_pattern.h>
#include <deal.II/lac/vector.h>

#include <irdm_common/geometry.h>
#include <reference_fem/elastodynamics.h>
#include <reference_fem/mesh.h>

#include "integrator.h"

#include <map>

namespace irdm::fem
{
  using namespace dealii;

  /// A sparse symmetric positive definite matrix factorized once (MUMPS Cholesky through
  /// PETSc, serial); every solve reuses the factors. About 9x faster per solve than UMFPACK
  /// on this machine class (shared/notes).
  class DirectSolver
  {
  public:
    void
    initialize(const SparseMatrix<double> &A);
    /// Solves A x = b in place.
    void
    solve(Vector<double> &rhs_and_solution) const;

  private:
    PETScWrappers::SparseMatrix                               matrix;
    mutable SolverControl                                     control;
    mutable std::unique_ptr<PETScWrappers::SparseDirectMUMPS> mumps;
    mutable PETScWrappers::MPI::Vector                        x, b;
  };

  /// A factorized matrix plus what is needed to impose prescribed vertex displacements on
  /// top of it without refactorizing: X = A^{-1} E_P and S = X_PP (Schur complement).
  struct ConstrainedSolver
  {
    DirectSolver                              inverse;
    std::vector<types::global_dof_index>      prescribed_dofs;
    std::vector<Vector<double>>               columns; // X
    FullMatrix<double>                        schur_inverse;

    void
    initialize(const SparseMatrix<double> &A,
               const AffineConstraints<double> &constraints,
               const std::vector<types::global_dof_index> &dofs);
    /// Solves A u = rhs + scale E_P lambda with u_P = g; returns lambda.
    Vector<double>
    solve(const AffineConstraints<double> &constraints,
          Vector<double> &rhs_in_u_out,
          const Vector<double> &g,
          double scale) const;
  };

  /// One plane's vertex contact at one step: force on the body (N), deepest penetration of
  /// a free surface vertex (m; negative: the gap).
  struct PlaneSample
  {
    Vec3   force{0, 0, 0};
    double penetration = 0;
  };

  class ElasticDynamics::Impl
  {
  public:
    explicit Impl(const Scene &scene);

    // step-8/step-23 shape: setup, assemble, then the time loop in run().
    void
    setup();
    void
    assemble();
    // The factors of the time step's K_eff, made on the first call (a precompute never steps
    // the FEM, and on a large mesh they cost as much as the eigensolver's own); later calls
    // return them.
    const ConstrainedSolver &
    stepper() const;
    RunResult
    run(const std::function<void(double)> &progress, const SampleSink &sink, unsigned batch);
    // run()'s start: the state at t = 0 (static equilibrium under the loads, or unstrained
    // and moving) with the probes' forces in f, and the probes' and planes' state then.
    void
    initial_state(Vector<double> &u, Vector<double> &v, Vector<double> &a, Vector<double> &f,
                  Vector<double> &lambda) const;
    void
    start_contacts(const Vector<double> &u);
    RunResult
    solve_static(double t) const;
    std::vector<double>
    natural_frequencies(unsigned n) const;
    void
    write_outputs(const RunResult &result) const;
    void
    write_vtu(const Vector<double> &u, unsigned step, double t,
              std::vector<std::pair<double, std::string>> &records) const;

    // Loads at time t (N, assembled): vertex forces, surface forces, gravity.
    void
    external_force(double t, Vector<double> &f) const;
    Vector<double>
    prescribed_values(double t) const;
    /// The scene's initial velocity at every DoF (m/s): the centre of mass's velocity plus the
    /// spin about it, w x (x - c) at the DoF's support point; 0 on constrained DoFs.
    Vector<double>
    initial_velocity() const;
    // The support point of every DoF (m): mesh vertices and, for P2, edge midpoints.
    std::vector<Point<3>>
    dof_support_points() const;
    void
    record(const Vector<double> &u, const Vector<double> &v, const Vector<double> &a,
           const Vector<double> &f, const Vector<double> &lambda, double t,
           RunResult &out) const;
    void
    init_result(RunResult &out) const;
    SparseMatrix<double>
    condensed(const SparseMatrix<double> &A) const;
    /// Free index of each DoF (-1 if constrained), in DoF order.
    std::vector<int>
    free_of_dof() const;
    /// Each free DoF's support point less the body's centre of mass (m; uniform density) and
    /// its axis, in free-index order (DenseSystem::free_dof_offset, free_dof_axis).
    void
    free_dof_geometry(std::vector<Vec3> &offset, std::vector<unsigned char> &axis) const;
    std::array<types::global_dof_index, 3>
    vertex_dofs(unsigned vertex) const;
    unsigned
    select_vertex(const VertexSelector &sel, const std::string &what) const;
    /// The scene's loads, prescribed displacements, probes and outputs on the mesh (setup's
    /// last part: after the surface and the constraints, which they are checked against).
    void
    place_scene_on_mesh();

    Scene   scene;
    TetMesh mesh;

    Triangulation<3>            triangulation;
    const MappingFE<3>          mapping;
    const FESystem<3>           fe;
    const QGaussSimplex<3>      quadrature;
    const QGaussSimplex<2>      face_quadrature;
    DoFHandler<3>               dof_handler;
    AffineConstraints<double>   constraints; // homogeneous: the fixed surfaces

    SparsityPattern      sparsity; // unconstrained: the full matrices also give reactions
    SparseMatrix<double> stiffness, mass;
    Vector<double>       gravity_force;
    std::vector<std::array<Vector<double>, 3>> surface_force_unit; // per surface load, per axis
    std::vector<double>                        surface_area;
    std::vector<std::array<types::global_dof_index, 3>> dofs_of_vertex;
    std::vector<unsigned> force_vertex, probe_vertex, observed_vertex;
    std::vector<unsigned> surface_vertices;
    std::vector<std::array<unsigned, 3>> surface_triangles;
    std::vector<int>                     surface_triangle_tag; // physical surface tag
    // Probes between vertices (scene.probes): candidate triangles per probe, and the
    // columns K_eff^{-1} e_i of the DoFs they have touched, computed on first touch.
    std::vector<std::vector<std::array<unsigned, 3>>>               probe_triangles;
    mutable std::map<types::global_dof_index, Vector<double>>      probe_columns;
    std::vector<std::array<double, 10>> last_probe; // the latest solve_probes() result
    const Vector<double> &
    probe_column(types::global_dof_index dof) const;
    /// Where probe p touches at time t: its contact point, and the mesh vertices its force
    /// spreads over with their weights (its triangle's barycentric weights, or the patch of a
    /// probe with a radius). InputError if a radius covers no vertex or too many.
    struct ProbeSpread
    {
      geometry::SurfacePoint at;
      std::vector<unsigned>  vertices;
      std::vector<double>    weights;
    };
    ProbeSpread
    probe_spread(unsigned p, double t) const;
    /// Imposes the probes at time t on u (free solution in, constrained solution out),
    /// adds their forces to f; returns per probe: force (3), contact point (3), active flag,
    /// displacement of the contact point (3).
    std::vector<std::array<double, 10>>
    solve_probes(double t, double scale, Vector<double> &u, Vector<double> &f) const;
    /// Imposes the planes at time t by vertex contact on u (free solution in, solution out),
    /// adds their forces to f (elastodynamics_planes.cc).
    std::vector<PlaneSample>
    solve_planes(double t, double scale, Vector<double> &u, Vector<double> &f) const;
    std::vector<PlaneSample> last_planes; // the latest solve_planes() result
    mutable std::vector<Vec3> plate_before; // a device-held plate's point, last step (m)
    std::vector<std::vector<types::global_dof_index>> fixed_dofs; // per fixed surface
    std::vector<types::global_dof_index> probe_dofs;
    std::vector<unsigned char> dof_component; // 0, 1, 2 = x, y, z
    double total_volume = 0;

    IntegratorCoefficients coeffs;
    double                 setup_seconds = 0;
    // Made by stepper() on first use.
    mutable SparseMatrix<double> effective;
    mutable ConstrainedSolver    step_solver;
    mutable bool                 factorized            = false;
    mutable double               factorization_seconds = 0;
  };
} // namespace irdm::fem
