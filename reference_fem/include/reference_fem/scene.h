#pragma once
// A scene: everything one reference-FEM run needs (mesh, material, damping, integrator, time,
// boundary conditions, loads, outputs). Read from a JSON file, format "irdm-scene/1",
// documented in docs/scene-format.md. Units are SI throughout (m, s, N, kg, Pa).
// This header is plain C++ (no deal.II) so downstream modules can read scenes cheaply.
#include <array>
#include <optional>
#include <string>
#include <vector>

namespace irdm::fem
{
  using Vec3 = std::array<double, 3>;

  /// A mesh vertex, named by its gmsh node tag or as the vertex nearest to a point.
  struct VertexSelector
  {
    long long           node_tag = -1; // >= 1 when given
    std::optional<Vec3> point;         // m
  };

  /// A vector-valued history, linear between samples and constant outside them.
  struct History
  {
    std::vector<double> times; // s, strictly increasing
    std::vector<Vec3>   values;

    Vec3
    at(double t) const;
    static History
    constant(const Vec3 &v);
  };

  struct VertexForce
  {
    std::string    name;
    VertexSelector vertex;
    History        force; // N
  };

  /// A total force spread over a named surface as a uniform traction (force / area).
  struct SurfaceForce
  {
    std::string name;
    std::string surface;
    History     total_force; // N
  };

  /// The haptic probe of the seed papers: a vertex follows a displacement history and the
  /// force it takes is reported.
  struct PrescribedDisplacement
  {
    std::string    name;
    VertexSelector vertex;
    History        displacement; // m
  };

  /// A scalar history, linear between samples and constant outside them.
  struct ScalarHistory
  {
    std::vector<double> times; // s, strictly increasing
    std::vector<double> values;

    double
    at(double t) const;
  };

  /// A haptic probe that touches the surface anywhere, not only at vertices (seed 000,
  /// section 2, with the contact point between vertices). At each step the contact point is
  /// the point of the named surface (undeformed) closest to path(t); the probe prescribes the
  /// displacement depth(t) * direction there, spread over the three vertices of its triangle
  /// by barycentric weights. The force it takes is reported. A unilateral probe pushes along
  /// 'direction' but never pulls: it lets go when it would pull and touches again when the
  /// surface would pass it.
  struct Probe
  {
    std::string   name;
    std::string   surface;   // named physical surface it may touch
    Vec3          direction; // unit vector, the direction it pushes in
    bool          unilateral = true;
    History       path;  // m, points near the undeformed surface
    ScalarHistory depth; // m, along direction
    double        until = 1e300; // s: the probe lets go for good after this time
    // m; > 0: a probe with a contact radius: its force spreads over the surface vertices
    // within this distance of the contact point by smooth weights (geometry::radius_patch),
    // so its force converges as the mesh is refined. 0: the point probe above.
    double radius = 0;
    // Virtual coupling (irdm_common/contact.h, contact::Coupling): the probe is a device that
    // pulls the probed point through a spring (N/m) and damper (N s/m), solved implicitly; a
    // unilateral probe is decided on the coupled force. Both 0: the rigid probe.
    double coupling_stiffness = 0;
    double coupling_damping   = 0;
  };

  /// A set of surface vertices: those of the named surfaces (all surfaces if none named),
  /// optionally only those within one of some balls. Vertices of fixed surfaces never belong
  /// to a set.
  struct VertexRegion
  {
    std::vector<std::string> surfaces;
    std::vector<std::pair<Vec3, double>> balls; // center (m), radius (m); empty: no limit
  };

  /// What an impulse-response model of this scene holds (irdm precompute).
  struct ModelSpec
  {
    unsigned                    length         = 500;   // T, samples of each response
    bool                        double_storage = false; // float (4 bytes) by default
    std::optional<VertexRegion> inputs;  // default: every free surface vertex
    std::optional<VertexRegion> outputs; // default: every free surface vertex
  };

  /// A frictionless plane (floor, wall) the body may touch. The plane passes through
  /// position(t) with the unit normal `normal`, which points to the side where the body is. A
  /// point x of the body surface penetrates by normal . (position(t) - x) when that is positive.
  /// Nonlinear kinematics: the plane pushes with the penalty traction
  /// penalty * penetration * normal, integrated over the boundary faces. Linear kinematics:
  /// vertex contact, the same the IRDM runtime does (irdm/vertex_contact.h): a normal force at
  /// each free surface vertex, complementary to its gap (rigid), or vertex_stiffness times its
  /// penetration solved implicitly (compliant).
  struct RigidPlane
  {
    std::string name;
    Vec3        normal;       // unit, toward the body
    History     normal_path;  // optional (nonlinear): a turning plane's normal over time,
                              // interpolated then made unit; empty: `normal` throughout
    History     position;     // m, a point of the plane over time (its prescribed motion)
    double      penalty = 0;  // Pa/m (traction per metre of penetration); 0: the default
                              // 100 E / h (h: mean boundary edge length)
    double      vertex_stiffness = 0; // N/m per vertex, linear kinematics; 0: rigid
    // Linear kinematics: a device-held plate. `position` is then the device's, and the plate
    // follows it through a spring (N/m) and damper (N s/m) along the normal, solved
    // implicitly with the contact (contact::Coupling). Both 0: the plane is where `position`
    // says.
    double      coupling_stiffness = 0;
    double      coupling_damping   = 0;

    /// The unit normal at time t (s).
    Vec3
    normal_at(double t) const;
  };

  struct ObservedVertex
  {
    std::string    name;
    VertexSelector vertex;
  };

  enum class Integrator
  {
    newmark,          // average acceleration: beta = 1/4, gamma = 1/2
    generalized_alpha // Chung-Hulbert, parametrised by rho_inf
  };

  /// Linear: small-strain elasticity (ElasticDynamics). Nonlinear: Total Lagrangian
  /// neo-Hookean with rigid-plane contact (NonlinearElasticity).
  enum class Kinematics
  {
    linear,
    nonlinear
  };

  enum class InitialState
  {
    rest,  // u = v = 0, a from the balance at t = 0
    static_equilibrium // u from K u = f(0), v = a = 0
  };

  struct Scene
  {
    std::string name;
    std::string source;     // file it was read from ("" if from a string)
    std::string json_text;  // the scene as given, stored with every result
    std::string mesh_file;  // resolved path
    unsigned    fe_degree = 2;
    // The linear FEM's mass matrix: consistent (exact integration), or "one_point": the
    // tetrahedron's rule at its centroid, rho V / 16 between every pair of its vertices, which is
    // what CalculiX's C3D4 element assembles. For cross-checking a model made by CalculiX; P1
    // and linear kinematics only.
    bool        one_point_mass = false;

    double youngs_modulus = 0; // Pa
    double poisson_ratio  = 0;
    double density        = 0; // kg/m^3

    // Rayleigh damping C = alpha M + beta K (alpha in 1/s, beta in s). If the scene gave
    // damping ratios at two frequencies, they are kept here too and alpha, beta solved from them.
    double                rayleigh_alpha = 0;
    double                rayleigh_beta  = 0;
    std::optional<Vec3>   damping_ratios_spec; // zeta1, zeta2 (unused third = 0)
    std::optional<Vec3>   damping_freqs_spec;  // f1, f2 in Hz (third = 0)

    Integrator   integrator = Integrator::newmark;
    double       rho_inf    = 1.0; // generalized-alpha spectral radius at infinity
    double       time_step  = 0;   // s
    double       duration   = 0;   // s
    InitialState initial    = InitialState::rest;

    Kinematics kinematics       = Kinematics::linear;
    // Nonlinear kinematics only: the small-strain law (sigma = lambda tr(eps) I + 2 mu eps, the
    // linear solver's) in place of neo-Hookean, the penalty plane contact kept. Separates what
    // geometric and material nonlinearity cost from what the contact discretization costs.
    bool       small_strain_law = false;
    // With small_strain_law (material.law "linear_body_frame"): that law in the body's own
    // frame, P = R (lambda tr(e) I + 2 mu e) with e = sym(R^T F) - I and R the rotation of the
    // body's best rigid fit weighed by the consistent mass (the mean-axis frame of a free
    // body's elastic modes), taken from the step's predicted motion. Linear elasticity in a
    // floating frame, what a free body's IRDM linearizes (irdm/free_body.h, docs/free-body.md):
    // unlike the plain small-strain law it strains nothing when the body turns as a whole.
    // Nonlinear dynamics only.
    bool       body_frame_law = false;
    // Nonlinear kinematics only (material.law "corotational"): the small-strain law in each
    // point's own rotation, R from the polar decomposition F = R S, P = R (lambda tr(e) I +
    // 2 mu e) with e = S - I (Mueller and Gross 2004; SOFA's corotational tetrahedra, with the
    // consistent tangent): objective like neo-Hookean, linear in the strain like the linear
    // law. Between the two it splits a miss into rotation and strain.
    bool       corotational_law = false;
    Vec3       initial_velocity = {0, 0, 0}; // m/s, of the centre of mass (a thrown or dropped body)
    // rad/s, world: a spin about the centre of mass, v(X) = initial_velocity + w x (X - c)
    // (a rigid velocity field: it strains nothing). Free bodies only.
    Vec3       initial_angular_velocity = {0, 0, 0};

    bool gravity_enabled = false;
    Vec3 gravity         = {0, 0, -9.81}; // m/s^2

    std::vector<std::string>            fixed_surfaces;
    std::vector<VertexForce>            vertex_forces;
    std::vector<SurfaceForce>           surface_forces;
    std::vector<PrescribedDisplacement> prescribed;
    std::vector<Probe>                  probes;
    std::vector<RigidPlane>             planes;
    ModelSpec                           model;

    struct Outputs
    {
      std::string                 directory; // resolved; empty: no files written
      std::vector<ObservedVertex> vertices;
      bool                        surface    = false; // all surface vertices
      // Every mesh vertex's displacement, kept in memory (RunResult::field_displacement) for
      // a caller that projects it (a reduced model's training); not a scene-file key.
      bool                        field      = false;
      unsigned                    every      = 1;     // keep every k-th step
      unsigned                    vtu_every  = 0;     // 0: no VTU output
      bool                        hdf5       = true;
      bool                        csv        = true;
    } outputs;

    unsigned
    n_steps() const; // duration / time_step, rounded; checked to be a whole number
  };

  /// Reads and validates a scene file. Relative paths inside it are relative to its folder.
  /// Throws InputError naming the offending key.
  Scene
  read_scene(const std::string &path);

  /// Same from a JSON string; base_dir resolves relative paths.
  Scene
  parse_scene(const std::string &json_text,
              const std::string &base_dir,
              const std::string &origin = "<string>");

  /// Rayleigh coefficients giving damping ratios zeta1 at f1 and zeta2 at f2 (Hz):
  /// zeta(omega) = alpha / (2 omega) + beta omega / 2.
  std::array<double, 2>
  rayleigh_from_ratios(double zeta1, double f1, double zeta2, double f2);
} // namespace irdm::fem
