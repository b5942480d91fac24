// The public runtime API (irdm/irdm.h) over the runtime's parts: each model kind and body
// kind is one alternative of a variant, so that a step is one dispatch (no virtual call) to
// the part's own step, with the public types turned into the part's targets on the way.
#include <irdm/free_body.h>
#include <irdm/irdm.h>
#include <irdm/modal_model.h>
#include <irdm/model.h>
#include <irdm/plane_interaction.h>
#include <irdm/point_interaction.h>
#include <irdm/reduced_nonlinear.h>
#include <irdm/representative_interaction.h>
#include <irdm/representative_model.h>
#include <irdm/state_space_interaction.h>
#include <irdm/state_space_model.h>
#include <irdm_common/contact.h>
#include <irdm_common/h5.h>

#include <Eigen/Geometry>

#include <algorithm>
#include <variant>

namespace irdm
{
  struct Model::Data
  {
    std::string          kind;
    ImpulseResponseModel impulse_response; // kinds modal (frame only) and direct
    ModalModel           modal;
    RepresentativeModel  representative;
    StateSpaceModel      state_space;
    VirtualDofModel      virtual_dofs;
    ReducedNonlinearModel reduced;
    std::vector<int>      reduced_inputs; // every surface vertex with a free DoF
    // The kind's own surface and inputs.
    const std::vector<std::array<double, 3>>   *rest      = nullptr;
    const std::vector<std::array<unsigned, 3>> *triangles = nullptr;
    const std::vector<int>                     *input_of_vertex = nullptr; // -1: none
    ModelOptions                                options;
    bool                                        free_body = false;
    double                                      mass      = 0;
    std::array<double, 3>                       center_of_mass{};
  };

  namespace
  {
    static_assert(Probe::max_patch == contact::max_patch);
    static_assert(StepInput::max_probes == contact::max_probes);
    static_assert(StepInput::max_planes == contact::max_planes);

    void
    use_frame(Model::Data &d, const ModelFrame &f)
    {
      d.rest            = &f.output_coordinates;
      d.triangles       = &f.triangles;
      d.input_of_vertex = &f.output_input_index;
      d.free_body       = f.free_body;
      d.mass            = f.mass;
      d.center_of_mass  = f.center_of_mass;
    }

    std::string
    file_format(const std::string &path)
    {
      const h5::Reader r(path); // InputError for a missing or non-HDF5 file
      return r.has_attribute("/", "format") ? r.string_attribute("/", "format") : std::string();
    }

    void
    load_impulse_response(Model::Data &d, const std::string &path)
    {
      const ModelOptions &o = d.options;
      d.impulse_response    = load_model(
        path, {}, o.direct ? ModelParts::impulse_response : ModelParts::modal_realization);
      ImpulseResponseModel &h = d.impulse_response;
      if (o.direct || h.modes.n_modes == 0)
        {
          if (h.modal_only)
            throw InputError("'" + path + "' holds the modal realization only: it cannot be "
                             "convolved directly (leave ModelOptions::direct off)");
          if (h.free_body)
            throw InputError("'" + path + "' is a free body: it runs from its modes only, and "
                             "the file holds none");
          d.kind = "direct";
          use_frame(d, h);
          return;
        }
      ModalModelOptions mo;
      mo.surface_modes = o.surface_modes == 0 ? h.modes.n_modes
                                              : std::min(o.surface_modes, h.modes.n_modes);
      mo.force_modes   = o.force_modes;
      if (mo.force_modes > 0 && mo.force_modes < mo.surface_modes)
        mo.surface_modes = mo.force_modes;
      d.modal = make_modal_model(h, mo);
      d.kind  = "modal";
      // The modal runtime keeps its own copy of what it needs: H is not read again.
      h.h_double = {};
      h.h_float  = {};
      use_frame(d, d.modal);
    }
  } // namespace

  Model
  Model::load(const std::string &path, const ModelOptions &options)
  {
    auto d     = std::make_shared<Data>();
    d->options = options;
    const std::string format = file_format(path);
    if (format == "irdm-impulse-response")
      load_impulse_response(*d, path);
    else if (format == "irdm-representative-model")
      {
        d->representative = load_representative_model(path);
        d->kind           = "representative";
        use_frame(*d, d->representative);
      }
    else if (format == "irdm-state-space-model")
      {
        d->state_space = load_state_space_model(path);
        d->kind        = "state_space";
        use_frame(*d, d->state_space);
      }
    else if (format == "irdm-reduced-model")
      {
        d->reduced = load_reduced_nonlinear_model(path);
        if (d->reduced.rigid_modes > 0)
          throw InputError("'" + path + "' is a free body's reduced model: the runtime API runs a "
                           "grounded one (a free one runs in irdm validate-free)");
        const ReducedNonlinearModel &r = d->reduced;
        d->kind                        = "reduced_nonlinear";
        d->rest                        = &r.coordinates;
        d->triangles                   = &r.triangles;
        d->reduced_inputs.resize(r.coordinates.size());
        for (size_t v = 0; v < r.coordinates.size(); ++v)
          d->reduced_inputs[v] = r.free_dof[v][0] || r.free_dof[v][1] || r.free_dof[v][2] ? int(v) : -1;
        d->input_of_vertex = &d->reduced_inputs;
      }
    else if (format == "irdm-virtual-dof-model")
      {
        d->virtual_dofs = load_virtual_dof_model(path);
        const VirtualDofModel &v = d->virtual_dofs;
        d->kind                  = "virtual_dof";
        d->rest                  = &v.coordinates;
        d->triangles             = &v.triangles;
        d->free_body             = v.free_body;
        d->mass                  = v.mass;
        d->center_of_mass        = v.center_of_mass;
      }
    else
      throw InputError("'" + path + "' is not an IRDM model (format '" + format +
                       "'; docs/model-format.md lists the kinds)");
    Model m;
    m.data_ = std::move(d);
    return m;
  }

  const std::string &
  Model::kind() const
  {
    return data_->kind;
  }
  bool
  Model::free_body() const
  {
    return data_->free_body;
  }
  double
  Model::time_step() const
  {
    const Data &d = *data_;
    if (d.kind == "modal")
      return d.modal.time_step;
    if (d.kind == "direct")
      return d.impulse_response.time_step;
    if (d.kind == "representative")
      return d.representative.time_step;
    if (d.kind == "state_space")
      return d.state_space.time_step;
    if (d.kind == "reduced_nonlinear")
      return d.reduced.time_step;
    return d.virtual_dofs.time_step;
  }
  const std::vector<std::array<double, 3>> &
  Model::rest_positions() const
  {
    return *data_->rest;
  }
  const std::vector<std::array<unsigned, 3>> &
  Model::triangles() const
  {
    return *data_->triangles;
  }
  bool
  Model::can_push(const unsigned v) const
  {
    const auto *in = data_->input_of_vertex;
    return in && v < in->size() && (*in)[v] >= 0;
  }
  double
  Model::mass() const
  {
    return data_->mass;
  }
  std::array<double, 3>
  Model::center_of_mass() const
  {
    return data_->center_of_mass;
  }

  SurfaceState
  Model::make_surface_state() const
  {
    if (data_->kind != "modal")
      throw InputError("a surface state exchanges a modal body's state; this model is of kind '" +
                       data_->kind + "' (use Body::surface_positions)");
    return irdm::make_surface_state(data_->modal);
  }

  void
  Model::surface_positions(const SurfaceState &state, double *x) const
  {
    const Data &d = *data_;
    if (d.kind != "modal" || state.modal_displacement.size() != d.modal.surface_modes)
      throw InputError("surface_positions: the state was not made for this model");
    surface_displacement(d.modal, state, x);
    const Eigen::Matrix3d R = Eigen::Quaterniond(state.orientation[0], state.orientation[1],
                                                 state.orientation[2], state.orientation[3])
                                .normalized()
                                .toRotationMatrix();
    const Eigen::Vector3d c = d.free_body ? vec(state.position) : vec(d.center_of_mass);
    const Eigen::Vector3d c0 = vec(d.center_of_mass);
    const auto           &X  = *d.rest;
    for (size_t v = 0; v < X.size(); ++v)
      {
        const Eigen::Vector3d u(x[3 * v], x[3 * v + 1], x[3 * v + 2]);
        const Eigen::Vector3d p = d.free_body ? Eigen::Vector3d(c + R * (vec(X[v]) - c0 + u))
                                              : Eigen::Vector3d(vec(X[v]) + u);
        for (int a = 0; a < 3; ++a)
          x[3 * v + a] = p(a);
      }
  }

  void
  Model::warm_surface(const std::size_t part, const std::size_t parts) const
  {
    if (data_->kind == "modal" && parts > 0 && part < parts)
      irdm::warm_surface(data_->modal, part, parts);
  }

  // ---------------------------------------------------------------------------------------
  // Body

  struct Body::State
  {
    Model              model_handle; // keeps the model's data alive as long as the body
    const Model::Data *model = nullptr;
    BodyOptions                        options;
    double                             tau = 0;
    std::variant<std::monostate, ModalInteraction, PointInteraction, RepresentativeInteraction,
                 StateSpaceInteraction, PlaneInteraction, FreeBodyInteraction, FreeBodyVirtualDofs,
                 ReducedNonlinearBody>
      runtime;

    // The parts' targets, filled from the public types each step.
    std::array<ProbeTarget, StepInput::max_probes>    probes;
    std::array<PlaneTarget, StepInput::max_planes>    planes;
    std::array<InputForce, StepInput::max_forces>     forces;
    std::array<AppliedForce, StepInput::max_forces>   world_forces;
    std::array<VirtualDofWall, PlaneInteraction::max_walls> walls;
    std::array<double, PlaneInteraction::max_walls>   wall_force{};
    // Virtual couplings: the device's and the coupled point's (or plate's) displacement or
    // position one step before, per probe or plane slot.
    std::array<std::array<double, 3>, StepInput::max_probes> probe_device{}, probe_point{};
    std::array<std::array<double, 3>, StepInput::max_planes> plate_device{}, plate{};
    std::array<bool, StepInput::max_planes>                  plate_known{};
    RigidStepCompliance                                      no_rigid_motion; // zero
    // A reduced nonlinear body's inputs, and which public probe each of its probes is.
    std::array<ReducedPlane, StepInput::max_planes>       reduced_planes;
    std::array<ReducedVertexForce, StepInput::max_forces> reduced_forces;
    std::array<ReducedProbe, StepInput::max_probes>       reduced_probes;
    std::array<int, StepInput::max_probes>                reduced_probe_of{};
    std::array<bool, StepInput::max_probes>               probe_was_present{};
    const char                                              *refusal = "";
    long long                                                steps   = 0;
  };

  namespace
  {
    using State = Body::State;

    const char *const refused_probes = "this body takes no probes (a free body: AppliedForce; "
                                       "a virtual-DOF model: planes only)";
    const char *const refused_planes = "this body takes no planes (a representative model: probes only)";
    const char *const refused_forces = "this body takes no applied forces";
    const char *const refused_mix    = "a grounded body takes probes, or planes and applied forces, "
                                       "not both in one step";
    const char *const refused_solve  = "the step could not be taken: a probe or force where the "
                                       "model has no input, or a bad value";

    // Probe -> ProbeTarget, its virtual coupling made a target and a compliance in series.
    void
    to_targets(State &s, const StepInput &in)
    {
      for (int p = 0; p < in.n_probes; ++p)
        {
          const Probe &a = in.probes[p];
          ProbeTarget &t = s.probes[p];
          t.triangle     = a.triangle;
          t.weights      = a.weights;
          t.n_patch      = std::clamp(a.n_patch, 0, Probe::max_patch);
          std::copy_n(a.patch_vertices.begin(), t.n_patch, t.patch_vertices.begin());
          std::copy_n(a.patch_weights.begin(), t.n_patch, t.patch_weights.begin());
          const contact::Coupling coupling{a.coupling_stiffness, a.coupling_damping};
          t.compliance   = coupling.compliance(s.tau);
          t.displacement = coupling.target(a.displacement, s.probe_device[p], s.probe_point[p], s.tau);
          t.direction    = a.direction;
          t.unilateral   = a.unilateral;
          t.present      = a.present;
          s.probe_device[p] = a.displacement;
        }
    }

    // Plane -> PlaneTarget; a device-held plate's coupling as for a probe, in positions (the
    // plate starts where its device is).
    void
    to_targets(State &s, const Plane *planes, const int n)
    {
      for (int p = 0; p < n; ++p)
        {
          const Plane &a = planes[p];
          PlaneTarget &t = s.planes[p];
          t.normal       = a.normal;
          t.stiffness    = a.stiffness;
          t.penalty      = a.penalty;
          const contact::Coupling coupling{a.coupling_stiffness, a.coupling_damping};
          if (!s.plate_known[p])
            s.plate_device[p] = s.plate[p] = a.point, s.plate_known[p] = true;
          t.coupling_compliance = coupling.compliance(s.tau);
          t.point = coupling.target(a.point, s.plate_device[p], s.plate[p], s.tau);
          s.plate_device[p] = a.point;
        }
    }

    // After the step: where each coupled plate stands, z - c (F . n) n.
    void
    record_plates(State &s, const StepOutput &out, const int n)
    {
      for (int p = 0; p < n; ++p)
        {
          const PlaneTarget &t = s.planes[p];
          const double       f = vec(out.plane_force[p]).dot(vec(t.normal));
          s.plate[p]           = arr(vec(t.point) - t.coupling_compliance * f * vec(t.normal));
        }
    }

    template <class Probed>
    void
    probe_results(State &s, const Probed &r, const int n, StepOutput &out)
    {
      for (int p = 0; p < n; ++p)
        {
          out.probe_force[p]        = r.force(p);
          out.probe_displacement[p] = r.probe_displacement(p);
          out.probe_active[p]       = r.active(p);
          s.probe_point[p]          = r.probe_displacement(p);
        }
    }

    // A step of a grounded body with probes only.
    template <class Probed>
    bool
    step_probes(State &s, Probed &r, const StepInput &in, StepOutput &out)
    {
      to_targets(s, in);
      if (!r.step(s.probes.data(), in.n_probes))
        return s.refusal = refused_solve, false;
      probe_results(s, r, in.n_probes, out);
      return true;
    }

    void
    plane_results(const VertexContact &c, const int n, StepOutput &out)
    {
      for (int p = 0; p < n; ++p)
        {
          out.plane_force[p]    = c.plane(p).force;
          out.plane_vertices[p] = c.plane(p).active;
        }
    }

    bool
    step_with(State &s, std::monostate &, const StepInput &, StepOutput &)
    {
      s.refusal = "moved-from body";
      return false;
    }

    // A grounded body with a modal or direct model: probes, or planes (and, modal, forces).
    template <class Runtime>
    bool
    step_grounded(State &s, Runtime &r, const StepInput &in, StepOutput &out)
    {
      if (in.n_probes > 0 && (in.n_planes > 0 || in.n_forces > 0))
        return s.refusal = refused_mix, false;
      if (in.n_planes > 0 || in.n_forces > 0)
        {
          to_targets(s, in.planes, in.n_planes);
          bool stepped = false;
          if constexpr (std::is_same_v<Runtime, ModalInteraction>)
            {
              for (int a = 0; a < in.n_forces; ++a)
                {
                  const unsigned v = in.forces[a].vertex;
                  if (!s.model_handle.can_push(v))
                    return s.refusal = refused_solve, false;
                  s.forces[a] = {static_cast<unsigned>((*s.model->input_of_vertex)[v]),
                                 in.forces[a].force};
                }
              stepped = in.n_forces > 0 ? r.step(s.planes.data(), in.n_planes, s.no_rigid_motion,
                                                 s.forces.data(), in.n_forces)
                                        : r.step(s.planes.data(), in.n_planes);
            }
          else
            {
              if (in.n_forces > 0)
                return s.refusal = refused_forces, false;
              stepped = r.step(s.planes.data(), in.n_planes);
            }
          if (!stepped)
            return s.refusal = refused_solve, false;
          plane_results(r.vertex_contact(), in.n_planes, out);
          record_plates(s, out, in.n_planes);
          return true;
        }
      return step_probes(s, r, in, out);
    }

    bool
    step_with(State &s, ModalInteraction &r, const StepInput &in, StepOutput &out)
    {
      return step_grounded(s, r, in, out);
    }
    bool
    step_with(State &s, PointInteraction &r, const StepInput &in, StepOutput &out)
    {
      return step_grounded(s, r, in, out);
    }
    bool
    step_with(State &s, StateSpaceInteraction &r, const StepInput &in, StepOutput &out)
    {
      return step_grounded(s, r, in, out);
    }

    bool
    step_with(State &s, RepresentativeInteraction &r, const StepInput &in, StepOutput &out)
    {
      if (in.n_planes > 0)
        return s.refusal = refused_planes, false;
      if (in.n_forces > 0)
        return s.refusal = refused_forces, false;
      return step_probes(s, r, in, out);
    }

    // Virtual DOFs: one wall per plane, d = -n (from the body toward the wall) at d . x = w.
    bool
    check_walls(State &s, const StepInput &in)
    {
      if (in.n_probes > 0)
        return s.refusal = refused_probes, false;
      if (in.n_forces > 0)
        return s.refusal = refused_forces, false;
      if (in.n_planes > PlaneInteraction::max_walls)
        return s.refusal = "a virtual-DOF model takes at most 4 planes", false;
      for (int p = 0; p < in.n_planes; ++p)
        if (in.planes[p].penalty > 0 || in.planes[p].coupling_stiffness > 0 ||
            in.planes[p].coupling_damping > 0)
          return s.refusal = "a virtual-DOF plane is rigid or has a stiffness: no penalty, no "
                             "coupling",
                 false;
      return true;
    }

    bool
    step_with(State &s, PlaneInteraction &r, const StepInput &in, StepOutput &out)
    {
      if (!check_walls(s, in))
        return false;
      for (int p = 0; p < in.n_planes; ++p)
        {
          const Eigen::Vector3d d = -vec(in.planes[p].normal);
          s.walls[p] = {arr(d), d.dot(vec(in.planes[p].point)), in.planes[p].stiffness};
        }
      if (!r.step(s.walls.data(), in.n_planes, s.wall_force.data()))
        return s.refusal = refused_solve, false;
      for (int p = 0; p < in.n_planes; ++p)
        {
          out.plane_force[p]    = arr(s.wall_force[p] * vec(in.planes[p].normal));
          out.plane_vertices[p] = 0; // one wall force per plane, on the virtual DOF's band
        }
      return true;
    }

    // A reduced nonlinear body: planes (penalty or stiffness), applied forces and probes through
    // a virtual coupling, all solved together in its Newton step.
    bool
    reduced_inputs(State &s, const StepInput &in, int &n_probes)
    {
      static_assert(StepInput::max_planes <= ReducedNonlinearBody::max_planes &&
                    StepInput::max_probes <= ReducedNonlinearBody::max_probes &&
                    Probe::max_patch <= ReducedProbe::max_patch);
      for (int p = 0; p < in.n_planes; ++p)
        {
          const Plane &a = in.planes[p];
          if (a.coupling_stiffness > 0 || a.coupling_damping > 0)
            return s.refusal = "a reduced nonlinear body's planes stand where they are given: no "
                               "plate coupling",
                   false;
          s.reduced_planes[p] = {a.normal, a.point, a.penalty, a.stiffness};
        }
      for (int a = 0; a < in.n_forces; ++a)
        {
          if (!s.model_handle.can_push(in.forces[a].vertex))
            return s.refusal = refused_solve, false;
          s.reduced_forces[a] = {in.forces[a].vertex, in.forces[a].force};
        }
      n_probes = 0;
      for (int p = 0; p < in.n_probes; ++p)
        {
          const Probe &a = in.probes[p];
          if (!(a.coupling_stiffness > 0))
            return s.refusal = "a reduced nonlinear body takes probes through a virtual coupling "
                               "(coupling_stiffness > 0)",
                   false;
          // The device's velocity over the step, from where it was one step before.
          std::array<double, 3> velocity{};
          if (s.probe_was_present[p])
            for (int d = 0; d < 3; ++d)
              velocity[d] = (a.displacement[d] - s.probe_device[p][d]) / s.tau;
          s.probe_device[p]      = a.displacement;
          s.probe_was_present[p] = a.present;
          if (!a.present)
            continue;
          ReducedProbe &r = s.reduced_probes[n_probes];
          if (a.n_patch > 0)
            {
              r.n_patch = std::min(a.n_patch, Probe::max_patch);
              std::copy_n(a.patch_vertices.begin(), r.n_patch, r.vertices.begin());
              std::copy_n(a.patch_weights.begin(), r.n_patch, r.weights.begin());
            }
          else
            {
              if (a.triangle < 0 || a.triangle >= static_cast<int>(s.model->triangles->size()))
                return s.refusal = refused_solve, false;
              r.n_patch = 3;
              for (int i = 0; i < 3; ++i)
                r.vertices[i] = (*s.model->triangles)[a.triangle][i], r.weights[i] = a.weights[i];
            }
          r.target = a.displacement, r.target_velocity = velocity, r.direction = a.direction;
          r.stiffness = a.coupling_stiffness, r.damping = a.coupling_damping, r.unilateral = a.unilateral;
          s.reduced_probe_of[n_probes++] = p;
        }
      return true;
    }

    bool
    step_with(State &s, ReducedNonlinearBody &b, const StepInput &in, StepOutput &out)
    {
      int n_probes = 0;
      if (!reduced_inputs(s, in, n_probes))
        return false;
      // A step Newton does not converge is still taken (its best iterate, counted); only a
      // refused input leaves the count and the state as they were.
      const unsigned long unconverged = b.failed_steps();
      if (!b.step(s.reduced_planes.data(), in.n_planes, s.reduced_forces.data(), in.n_forces,
                  s.reduced_probes.data(), n_probes) &&
          b.failed_steps() == unconverged)
        return s.refusal = refused_solve, false;
      for (int p = 0; p < in.n_planes; ++p)
        {
          out.plane_force[p]    = b.plane_force(p);
          out.plane_vertices[p] = b.plane_vertices(p);
        }
      for (int p = 0; p < in.n_probes; ++p)
        out.probe_force[p] = {0, 0, 0}, out.probe_active[p] = false;
      for (int i = 0; i < n_probes; ++i)
        {
          const int   p = s.reduced_probe_of[i];
          const auto &f = b.probe_force(i);
          out.probe_force[p]        = f;
          out.probe_displacement[p] = b.probe_displacement(i);
          out.probe_active[p]       = f[0] != 0 || f[1] != 0 || f[2] != 0;
        }
      return true;
    }

    template <class Deformation>
    void
    rigid_results(const FreeBody<Deformation> &b, StepOutput &out)
    {
      const RigidBodyState &r = b.rigid().state();
      out.position            = arr(r.position);
      out.orientation         = {r.orientation.w(), r.orientation.x(), r.orientation.y(),
                                 r.orientation.z()};
      out.velocity            = arr(b.rigid().velocity());
      out.angular_velocity    = arr(b.rigid().angular_velocity());
    }

    bool
    step_with(State &s, FreeBodyInteraction &b, const StepInput &in, StepOutput &out)
    {
      if (in.n_probes > 0)
        return s.refusal = refused_probes, false;
      to_targets(s, in.planes, in.n_planes);
      if (!b.step(s.planes.data(), in.n_planes, in.forces, in.n_forces))
        return s.refusal = refused_solve, false;
      for (int p = 0; p < in.n_planes; ++p)
        {
          out.plane_force[p]    = arr(b.plane_force(p));
          out.plane_vertices[p] = b.deformation().plane_result(p).active;
        }
      record_plates(s, out, in.n_planes);
      rigid_results(b, out);
      return true;
    }

    bool
    step_with(State &s, FreeBodyVirtualDofs &b, const StepInput &in, StepOutput &out)
    {
      if (!check_walls(s, in))
        return false;
      to_targets(s, in.planes, in.n_planes);
      if (!b.step(s.planes.data(), in.n_planes))
        return s.refusal = refused_solve, false;
      for (int p = 0; p < in.n_planes; ++p)
        out.plane_force[p] = arr(b.plane_force(p));
      rigid_results(b, out);
      return true;
    }
  } // namespace

  Body::Body(const Model &model, const BodyOptions &o)
    : state_(std::make_unique<State>())
  {
    State &s       = *state_;
    s.model_handle = model;
    s.model        = &s.model_handle.data();
    s.options      = o;
    s.tau          = model.time_step();
    const Model::Data   &d = model.data();
    VertexContactOptions contact;
    contact.margin         = o.contact_margin;
    contact.max_candidates = o.max_contact_vertices;
    if (!(o.contact_margin >= 0) || o.max_contact_vertices == 0)
      throw InputError("BodyOptions: contact_margin must be >= 0 m and max_contact_vertices > 0");
    if (!d.free_body)
      {
        if (o.centrifugal || o.deformed_inertia || o.euler || o.spin_softening || o.coriolis ||
            o.deformation_momentum)
          throw InputError("BodyOptions: the frame's forces and deformed_inertia are for a free body; "
                           "this model is grounded");
        if (d.kind == "modal")
          s.runtime.emplace<ModalInteraction>(d.modal, contact);
        else if (d.kind == "direct")
          s.runtime.emplace<PointInteraction>(d.impulse_response, d.options.taps, contact);
        else if (d.kind == "representative")
          s.runtime.emplace<RepresentativeInteraction>(d.representative);
        else if (d.kind == "state_space")
          s.runtime.emplace<StateSpaceInteraction>(d.state_space, contact);
        else if (d.kind == "reduced_nonlinear")
          s.runtime.emplace<ReducedNonlinearBody>(d.reduced);
        else
          s.runtime.emplace<PlaneInteraction>(d.virtual_dofs,
                                              o.interpolate_orientations
                                                ? OrientationMapping::interpolated_same_contact
                                                : OrientationMapping::nearest);
        return;
      }
    FreeBodyOptions fo;
    fo.gravity          = vec(o.gravity);
    fo.contact          = contact;
    fo.mapping          = o.interpolate_orientations ? OrientationMapping::interpolated_same_contact
                                                     : OrientationMapping::nearest;
    fo.centrifugal      = o.centrifugal;
    fo.deformed_inertia = o.deformed_inertia;
    fo.euler            = o.euler;
    fo.spin_softening   = o.spin_softening;
    fo.coriolis         = o.coriolis;
    fo.frame_modes      = o.frame_modes;
    fo.deformation_momentum = o.deformation_momentum;
    if (d.kind == "modal")
      s.runtime.emplace<FreeBodyInteraction>(d.modal, fo);
    else if (d.kind == "virtual_dof")
      s.runtime.emplace<FreeBodyVirtualDofs>(d.virtual_dofs, fo);
    else
      throw InputError("a free body runs from a modal or virtual-DOF model, not kind '" + d.kind + "'");
  }

  Body::~Body()                = default;
  Body::Body(Body &&) noexcept = default;
  Body &
  Body::operator=(Body &&) noexcept = default;

  bool
  Body::step(const StepInput &in, StepOutput &out)
  {
    State &s = *state_;
    if (in.n_probes < 0 || in.n_probes > StepInput::max_probes || in.n_planes < 0 ||
        in.n_planes > StepInput::max_planes || in.n_forces < 0 ||
        in.n_forces > StepInput::max_forces || (in.n_probes > 0 && !in.probes) ||
        (in.n_planes > 0 && !in.planes) || (in.n_forces > 0 && !in.forces))
      {
        s.refusal = "a count out of range (StepInput::max_probes, max_planes, max_forces) or a "
                    "null array";
        return false;
      }
    const bool stepped =
      std::visit([&](auto &runtime) { return step_with(s, runtime, in, out); }, s.runtime);
    if (!stepped)
      return false;
    s.refusal = "";
    ++s.steps;
    out.steps = s.steps;
    out.time  = s.steps * s.tau;
    return true;
  }

  const char *
  Body::refusal() const
  {
    return state_->refusal;
  }

  void
  Body::set_motion(const std::array<double, 3> &center_of_mass,
                   const std::array<double, 4> &orientation, const std::array<double, 3> &velocity,
                   const std::array<double, 3> &angular_velocity)
  {
    const auto apply = [&](RigidBody &r) {
      const Eigen::Quaterniond q(orientation[0], orientation[1], orientation[2], orientation[3]);
      if (!(q.norm() > 0) || !vec(center_of_mass).allFinite() || !vec(velocity).allFinite() ||
          !vec(angular_velocity).allFinite() || !q.coeffs().allFinite())
        throw InputError("set_motion: a non-finite value or a zero quaternion");
      RigidBodyState st = r.state();
      st.position       = vec(center_of_mass);
      st.orientation    = q.normalized();
      r.set_state(st);
      r.set_velocity(vec(velocity), vec(angular_velocity));
    };
    if (auto *b = std::get_if<FreeBodyInteraction>(&state_->runtime))
      apply(b->rigid());
    else if (auto *v = std::get_if<FreeBodyVirtualDofs>(&state_->runtime))
      apply(v->rigid());
    else
      throw InputError("set_motion: this body is grounded");
  }

  void
  Body::surface_displacement(double *u) const
  {
    std::visit(
      [&](auto &r) {
        using R = std::decay_t<decltype(r)>;
        if constexpr (std::is_same_v<R, PlaneInteraction>)
          std::copy(r.update_surface().begin(), r.update_surface().end(), u);
        else if constexpr (std::is_same_v<R, FreeBodyInteraction> ||
                           std::is_same_v<R, FreeBodyVirtualDofs>)
          r.deformation().surface_displacement(u);
        else if constexpr (!std::is_same_v<R, std::monostate>)
          r.surface_displacement(u);
      },
      state_->runtime);
  }

  void
  Body::surface_positions(double *x) const
  {
    State &s = *state_;
    if (auto *b = std::get_if<FreeBodyInteraction>(&s.runtime))
      return b->surface_positions(x);
    if (auto *v = std::get_if<FreeBodyVirtualDofs>(&s.runtime))
      return v->surface_positions(x);
    surface_displacement(x);
    const auto &X = *s.model->rest;
    for (size_t v = 0; v < X.size(); ++v)
      for (int a = 0; a < 3; ++a)
        x[3 * v + a] += X[v][a];
  }

  void
  Body::save_surface_state(SurfaceState &state) const
  {
    State &s = *state_;
    if (auto *m = std::get_if<ModalInteraction>(&s.runtime))
      return m->save_surface_state(state);
    if (auto *b = std::get_if<FreeBodyInteraction>(&s.runtime))
      {
        b->deformation().interaction().save_surface_state(state);
        const RigidBodyState &r = b->rigid().state();
        state.position          = arr(r.position);
        state.orientation       = {r.orientation.w(), r.orientation.x(), r.orientation.y(),
                                   r.orientation.z()};
        return;
      }
    throw InputError("save_surface_state: only a modal body saves a surface state");
  }

  void
  Body::warm_step() const
  {
    if (const auto *m = std::get_if<ModalInteraction>(&state_->runtime))
      m->warm_step();
    else if (const auto *b = std::get_if<FreeBodyInteraction>(&state_->runtime))
      b->deformation().interaction().warm_step();
  }

  double
  Body::energy() const
  {
    if (const auto *m = std::get_if<ModalInteraction>(&state_->runtime))
      return m->elastic_energy();
    if (const auto *b = std::get_if<FreeBodyInteraction>(&state_->runtime))
      return b->energy();
    if (const auto *v = std::get_if<FreeBodyVirtualDofs>(&state_->runtime))
      return v->energy();
    if (const auto *r = std::get_if<ReducedNonlinearBody>(&state_->runtime))
      return r->energy();
    return 0;
  }

  const Model &
  Body::model() const
  {
    return state_->model_handle;
  }

  namespace
  {
    /// The body's many-vertex contact, or null.
    const VertexContact *
    vertex_contact_of(const State &s)
    {
      if (const auto *m = std::get_if<ModalInteraction>(&s.runtime))
        return &m->vertex_contact();
      if (const auto *p = std::get_if<PointInteraction>(&s.runtime))
        return &p->vertex_contact();
      if (const auto *p = std::get_if<StateSpaceInteraction>(&s.runtime))
        return &p->vertex_contact();
      if (const auto *b = std::get_if<FreeBodyInteraction>(&s.runtime))
        return &b->deformation().interaction().vertex_contact();
      return nullptr;
    }
  } // namespace

  unsigned long
  Body::contact_limited_steps() const
  {
    const VertexContact *c = vertex_contact_of(*state_);
    return c ? c->limited_steps() : 0;
  }

  unsigned long
  Body::unconverged_steps() const
  {
    const auto *r = std::get_if<ReducedNonlinearBody>(&state_->runtime);
    return r ? r->failed_steps() : 0;
  }

  unsigned long
  Body::contact_fallback_steps() const
  {
    const VertexContact *c = vertex_contact_of(*state_);
    return c ? c->fallback_steps() : 0;
  }
} // namespace irdm
