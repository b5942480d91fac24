#pragma once
// The IRDM runtime for a haptic application: the whole public API (docs/runtime-api.md).
//
//   Model  a model file of any kind, loaded and checked (before the loops start: it allocates)
//   Body   the body it describes, grounded or free, with its contact state
//   step   one force-loop step: StepInput (probes, planes, applied forces) -> StepOutput
//   surface  the deformed surface, now (Body) or from a saved state in another thread
//            (SurfaceState through a TripleBuffer, irdm/surface_exchange.h)
//
// Units SI. A model's time step tau is one force-loop step; a force f[n] is held during step n
// (impulse = f tau). A grounded body works in the model's frame; a free body takes its planes
// and applied forces in the world frame and reports its pose there.
// Body::step allocates nothing, takes no lock and makes no virtual call.
#include <irdm_common/error.h>

#include <array>
#include <cstddef>
#include <memory>
#include <string>
#include <vector>

namespace irdm
{
  /// How a model is prepared for the runtime. The modal realization (the exact model, every
  /// mode in the force loop) is used whenever the file holds one.
  struct ModelOptions
  {
    // M: modes in the full surface update, the rest as a static correction (0: every mode).
    unsigned surface_modes = 100;
    // K: modes in the force loop's history (0: every mode, the exact model). Fewer make the
    // step cheaper; the modes beyond K respond quasi-statically.
    unsigned force_modes = 0;
    // Convolve H directly instead of running its modal realization (a grounded model with H;
    // as exact, at a cost that grows with the response length).
    bool direct = false;
    // With `direct`: samples of each response used (0: all).
    unsigned taps = 0;
  };

  struct SurfaceState;

  /// A model file written by `irdm precompute` (impulse responses, with or without H; with
  /// --reduced a reduced nonlinear model), `irdm precompute-vdof` (virtual DOFs) or
  /// `irdm compress` (representative waveforms).
  /// Copies share the loaded data; it is read-only once loaded.
  class Model
  {
  public:
    /// Throws InputError for a missing or bad file (docs/model-format.md).
    static Model
    load(const std::string &path, const ModelOptions &options = {});

    /// "modal", "direct", "representative", "state_space" (irdm compress --method era),
    /// "virtual_dof" or "reduced_nonlinear" (irdm precompute --reduced).
    const std::string &
    kind() const;
    bool
    free_body() const;
    double
    time_step() const; // s
    /// The model's surface: vertex positions (m, model frame, undeformed) and outward
    /// triangles of vertex indices. Every vertex index in this API is into these.
    const std::vector<std::array<double, 3>> &
    rest_positions() const;
    const std::vector<std::array<unsigned, 3>> &
    triangles() const;
    /// Whether a probe or an applied force may act at vertex v (it is one of the model's
    /// inputs; a reduced nonlinear model: any surface vertex with a free DoF). A virtual-DOF
    /// model takes planes only: false everywhere.
    bool
    can_push(unsigned v) const;
    /// A free body's mass (kg) and centre of mass (m, model frame); 0 for a grounded one.
    double
    mass() const;
    std::array<double, 3>
    center_of_mass() const;

    /// For the deformation thread of the two-loop runtime (modal kind only, else InputError):
    /// a state sized for this model (allocates; make it before the loops start), and the
    /// world positions of every surface vertex from a state a Body saved (3 per vertex, m;
    /// a grounded body's are in the model frame). Allocates nothing.
    SurfaceState
    make_surface_state() const;
    void
    surface_positions(const SurfaceState &state, double *x) const;
    /// Reads part `part` (0 to parts - 1) of the surface shapes into this core's cache, so that
    /// the next surface_positions finds them there. Deformation thread only, between frames.
    void
    warm_surface(std::size_t part = 0, std::size_t parts = 1) const;

    struct Data;
    const Data &
    data() const
    {
      return *data_;
    }

  private:
    std::shared_ptr<const Data> data_;
  };

  /// A probe: the device holds a surface point (a point of a triangle by barycentric weights,
  /// or a patch of vertices with weights summing to 1) and moves it by `displacement` from
  /// its rest position. With a virtual coupling (Colgate et al. 1995) the point follows the
  /// device through a spring and a damper, solved implicitly with the body: recommended for a
  /// real device. Grounded bodies only.
  struct Probe
  {
    static constexpr int max_patch = 256;
    int                   triangle = -1;        // index into Model::triangles() (n_patch == 0)
    std::array<double, 3> weights  = {1, 0, 0}; // barycentric, on its vertices
    int                                  n_patch = 0; // > 0: these vertices instead
    std::array<unsigned, max_patch>      patch_vertices{};
    std::array<double, max_patch>        patch_weights{};
    std::array<double, 3> displacement = {0, 0, 0}; // m, the device's, model frame
    double                coupling_stiffness = 0;   // N/m; with damping 0 as well: rigid probe
    double                coupling_damping   = 0;   // N s/m
    std::array<double, 3> direction          = {0, 0, -1}; // unit push direction
    bool                  unilateral         = false; // pushes only along direction
    bool                  present            = true;  // false: no contact this step
  };

  /// A frictionless plane (floor, wall, device-held plate) that every surface vertex may
  /// touch. Grounded body: model frame; free body: world frame.
  struct Plane
  {
    std::array<double, 3> normal    = {0, 0, 1}; // unit, toward the body
    std::array<double, 3> point     = {0, 0, 0}; // m, a point of it at the step's end
    double                stiffness = 0;         // N/m per vertex (virtual DOF: per wall); 0: rigid
    double                penalty   = 0;         // Pa/m times each vertex's area (> 0: replaces stiffness)
    // A device-held plate: `point` is the device's, and the plate follows it through a
    // virtual coupling (both 0: the plane is at `point`). Many-vertex contact only.
    double coupling_stiffness = 0; // N/m
    double coupling_damping   = 0; // N s/m
  };

  /// A known force on a surface vertex during one step (N; grounded: model frame, free:
  /// world). The vertex must be one the model can push (Model::can_push).
  struct AppliedForce
  {
    unsigned              vertex = 0;
    std::array<double, 3> force{};
  };

  /// What one step is given. What each body takes: a grounded modal, direct or state-space
  /// body probes, or planes and applied forces (the direct and state-space kinds: planes
  /// only); a representative model
  /// probes; a free modal body planes and applied forces; a virtual-DOF model planes (at
  /// most 4); a reduced nonlinear body planes (no plate coupling), applied forces and probes
  /// through a virtual coupling, all in one step. Anything else is refused (Body::step
  /// returns false and says why).
  struct StepInput
  {
    static constexpr int max_probes = 4, max_planes = 8, max_forces = 16;
    const Probe        *probes   = nullptr;
    int                 n_probes = 0;
    const Plane        *planes   = nullptr;
    int                 n_planes = 0;
    const AppliedForce *forces   = nullptr;
    int                 n_forces = 0;
  };

  /// What one step gives: the contact forces on the body (N; the device feels their
  /// negatives), the probed points' displacements (m) and, for a free body, its rigid motion
  /// after the step (world frame; centre of mass, orientation as a unit quaternion w, x, y, z
  /// taking the model frame to the world).
  struct StepOutput
  {
    long long                                                 steps = 0; // taken so far
    double                                                    time  = 0; // s, after this step
    std::array<std::array<double, 3>, StepInput::max_probes>  probe_force{};
    std::array<std::array<double, 3>, StepInput::max_probes>  probe_displacement{};
    std::array<bool, StepInput::max_probes>                   probe_active{};
    std::array<std::array<double, 3>, StepInput::max_planes>  plane_force{};
    std::array<int, StepInput::max_planes>                    plane_vertices{}; // pushed
    std::array<double, 3> position{}, velocity{}, angular_velocity{}; // m, m/s, rad/s
    std::array<double, 4> orientation = {1, 0, 0, 0};
  };

  /// What the full surface update needs of a modal body's state after a step, so that
  /// another thread can draw the surface (Body::save_surface_state, Model::surface_positions).
  /// Sized by Model::make_surface_state: filling it allocates nothing.
  struct SurfaceState
  {
    long long             steps = 0;           // the state at time steps * time_step
    std::vector<double>   modal_displacement;  // [surface mode]
    std::vector<unsigned> pushed_inputs;       // input DoFs with force this step
    std::vector<double>   pushed_forces;       // N, the force on each of them
    unsigned              n_pushed = 0;
    std::array<double, 3> position{};          // a free body's centre of mass (m, world)
    std::array<double, 4> orientation = {1, 0, 0, 0};
  };

  struct BodyOptions
  {
    std::array<double, 3> gravity = {0, 0, -9.81}; // m/s^2, world; free bodies
    // Many-vertex plane contact: vertices within this distance of a plane (m) are candidates
    // (it must exceed the surface's motion toward a plane in one step), at most this many: a
    // step with more solves the deepest of them (Body::contact_limited_steps counts it).
    double   contact_margin       = 0.005;
    unsigned max_contact_vertices = 512;
    // Free modal body: the spin's centrifugal force on the deformation, and the deformed
    // body's inertia (both need a model with /modes/centrifugal_load).
    bool centrifugal      = false;
    bool deformed_inertia = false;
    // Free modal body: the moving frame's other forces on the deformation, the Euler force,
    // the spin softening and the Coriolis force (need /modes/inertial_coupling;
    // docs/free-body.md).
    bool euler = false, spin_softening = false, coriolis = false;
    // Free modal body: the rigid body's angular momentum to second order in the deformation,
    // the deformation's own angular momentum and (with deformed_inertia) the inertia's
    // second-order change (need /modes/inertial_coupling; docs/free-body.md).
    bool deformation_momentum = false;
    unsigned frame_modes = 0; // the lowest modes they act on; 0: every one the model holds
    // Virtual DOFs: blend the dome's orientations around a plane's normal instead of taking
    // the nearest.
    bool interpolate_orientations = false;
  };

  /// The body of a model at run time. Construct it before the loops start (it allocates);
  /// then step it from one thread. Movable, not copyable.
  class Body
  {
  public:
    /// Throws InputError if the options do not fit the model (docs/runtime-api.md).
    explicit Body(const Model &model, const BodyOptions &options = {});
    ~Body();
    Body(Body &&) noexcept;
    Body &
    operator=(Body &&) noexcept;

    /// One step. Returns false, takes no step and fills nothing if the input is not one this
    /// body takes or cannot be solved (refusal() says why).
    bool
    step(const StepInput &input, StepOutput &output);
    /// Why the latest step returned false ("" after a step taken).
    const char *
    refusal() const;

    /// A free body's motion before its first step (world; orientation w, x, y, z). Its
    /// default: the model frame's pose, at rest. InputError for a grounded body.
    void
    set_motion(const std::array<double, 3> &center_of_mass,
               const std::array<double, 4> &orientation, const std::array<double, 3> &velocity,
               const std::array<double, 3> &angular_velocity);

    /// The surface after the latest step, 3 per vertex: displacement (m, model frame) and
    /// world positions. They cost O(vertices x modes): deformation thread, or between steps.
    void
    surface_displacement(double *u) const;
    void
    surface_positions(double *x) const;
    /// Copies what Model::surface_positions needs into `state` (modal kind; made by
    /// Model::make_surface_state). Allocates nothing; for the force thread.
    void
    save_surface_state(SurfaceState &state) const;
    /// Reads what the next step reads, so that it finds it in this core's cache: for a force
    /// thread waiting for its tick. Changes nothing.
    void
    warm_step() const;
    /// The body's energy (J): kinetic and strain energy of the deformation's modes, plus a
    /// free body's rigid kinetic energy (gravity's potential not included). 0 where the model
    /// does not know it (direct, representative, virtual DOF deformation).
    double
    energy() const;

    const Model &
    model() const;

    /// Many-vertex contact's fallbacks so far (docs/runtime-api.md): steps with more
    /// candidates than max_contact_vertices, which solved the deepest of them, and steps whose
    /// contact solve refused and took projected Gauss-Seidel's approximate answer. Both are
    /// steps taken, not refused; 0 for a body without many-vertex contact.
    unsigned long
    contact_limited_steps() const;
    /// A reduced nonlinear body's steps where Newton did not converge (taken all the same,
    /// from its best iterate, after the step was solved again in up to 16 parts); 0 otherwise.
    unsigned long
    unconverged_steps() const;
    unsigned long
    contact_fallback_steps() const;

    struct State;

  private:
    std::unique_ptr<State> state_;
  };
} // namespace irdm
