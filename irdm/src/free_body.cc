// A free body at run time: rigid motion and deformation in the body frame (irdm/free_body.h).
#include <irdm/free_body.h>
#include <irdm_common/error.h>

namespace irdm
{
  namespace
  {
    // The rigid body of a free-body model; `grounded` is the error for a model of a grounded
    // body.
    RigidBodyInertia
    inertia_from(const bool free_body, const char *grounded, const double mass,
                 const std::array<double, 3> &center,
                 const std::array<std::array<double, 3>, 3> &inertia)
    {
      if (!free_body)
        throw InputError(grounded);
      RigidBodyInertia in;
      in.mass   = mass;
      in.center = vec(center);
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
          in.inertia(i, j) = inertia[i][j];
      return in;
    }
  } // namespace

  // ---- The modal deformation under many-vertex contact.

  RigidBodyInertia
  ModalDeformation::inertia(const ModalModel &m)
  {
    return inertia_from(m.free_body,
                        "free body: the model is of a grounded body (it has a fixed surface); "
                        "precompute a scene with no fixed surface",
                        m.mass, m.center_of_mass, m.inertia);
  }

  ModalDeformation::ModalDeformation(const ModalModel &model, const FreeBodyOptions &options)
    : model_(model)
    , interaction_(model, options.contact)
    , vertex_done_(model.n_inputs / 3, 0)
    , centrifugal_(options.centrifugal)
  {
    if ((options.centrifugal || options.deformed_inertia) && model.centrifugal_load.empty())
      throw InputError("free body: the centrifugal force and the deformed inertia need a model "
                       "with /modes/centrifugal_load (irdm precompute, this version)");
    if (!interaction_.set_frame_forces(options.euler, options.spin_softening, options.coriolis,
                                       options.frame_modes) ||
        (options.deformation_momentum && model.inertial_modes == 0))
      throw InputError("free body: the Euler, spin-softening and Coriolis forces and the "
                       "deformation's momentum need a model with /modes/inertial_coupling "
                       "(irdm precompute's dense route, this version)");
  }

  bool
  ModalDeformation::step(const PlaneTarget *body_planes, const int n_planes,
                         const RigidStepCompliance &rigid, const InputForce *applied,
                         const int n_applied)
  {
    return interaction_.step(body_planes, n_planes, rigid, applied, n_applied);
  }

  void
  ModalDeformation::contact_wrench(const Eigen::Vector3d &center, Eigen::Vector3d &force,
                                   Eigen::Vector3d &torque)
  {
    force.setZero();
    torque.setZero();
    for (const unsigned k : interaction_.pushed_inputs())
      {
        const unsigned vertex = k / 3;
        if (vertex_done_[vertex])
          continue; // its three DoFs are taken together
        vertex_done_[vertex] = 1;
        Eigen::Vector3d f, r = vec(model_.output_coordinates[model_.input_output_index[vertex]]) - center;
        for (int d = 0; d < 3; ++d)
          {
            f(d) = interaction_.force_on_input(3 * vertex + d);
            r(d) += interaction_.lever_displacement(3 * vertex + d);
          }
        force += f;
        torque += r.cross(f);
      }
    for (const unsigned k : interaction_.pushed_inputs())
      vertex_done_[k / 3] = 0;
  }

  Eigen::Vector3d
  ModalDeformation::plane_force(const int p) const
  {
    return vec(interaction_.vertex_contact().plane(p).force);
  }

  // ---- The seed's virtual DOFs.

  RigidBodyInertia
  VirtualDofDeformation::inertia(const VirtualDofModel &m)
  {
    return inertia_from(m.free_body,
                        "free body: the virtual-DOF model is of a grounded body (it has a fixed "
                        "surface); run irdm precompute-vdof on a scene with no fixed surface",
                        m.mass, m.center_of_mass, m.inertia);
  }

  VirtualDofDeformation::VirtualDofDeformation(const VirtualDofModel &model,
                                               const FreeBodyOptions &options)
    : model_(model)
    , interaction_(model, options.mapping)
  {
    if (options.centrifugal || options.deformed_inertia || options.frame_forces() ||
        options.deformation_momentum)
      throw InputError("free body: the virtual DOFs hold no mode shapes, so neither the "
                       "frame's inertial forces nor the deformed inertia can be taken in");
  }

  bool
  VirtualDofDeformation::step(const PlaneTarget *body_planes, const int n_planes,
                              const RigidStepCompliance &rigid, const InputForce *,
                              const int n_applied)
  {
    if (n_planes < 0 || n_planes > PlaneInteraction::max_walls || n_applied != 0)
      return false;
    // A plane (normal n toward the body, through p) is the wall {x : d . x > w} with d = -n,
    // w = d . p, as stiff as the precompute's penalty wall: the wall the responses were made
    // with, so that replaying the precompute gives back its force (test
    // FreeBodyRuntime.VirtualDofBodyReplaysItsPrecomputedHit). It does not cure the bounce of
    // a stiff wall: a wall that stops the body within one step bounces it off faster than it
    // came, through the trapezoidal impulse (the free beam dropped 0.5 mm bounced 3.7 mm).
    std::array<VirtualDofWall, PlaneInteraction::max_walls> walls;
    for (int a = 0; a < n_planes; ++a)
      {
        const auto &n = body_planes[a].normal, &p = body_planes[a].point;
        walls[a].direction = {-n[0], -n[1], -n[2]};
        walls[a].position  = -(n[0] * p[0] + n[1] * p[1] + n[2] * p[2]);
        walls[a].stiffness = VirtualDofWall::precompute_wall;
      }
    n_walls_ = n_planes;
    return interaction_.step(walls.data(), n_planes, force_.data(), rigid);
  }

  void
  VirtualDofDeformation::contact_wrench(const Eigen::Vector3d &center, Eigen::Vector3d &force,
                                        Eigen::Vector3d &torque)
  {
    force.setZero();
    torque.setZero();
    for (int a = 0; a < n_walls_; ++a)
      {
        const Eigen::Vector3d f = plane_force(a);
        force += f;
        torque += (vec(interaction_.contact_point(a)) - center).cross(f);
      }
  }

  Eigen::Vector3d
  VirtualDofDeformation::plane_force(const int p) const
  {
    // Wall p pushes along -d = its plane's normal.
    return p < n_walls_ ? Eigen::Vector3d(-force_[p] * vec(interaction_.wall_direction(p)))
                        : Eigen::Vector3d::Zero();
  }

  void
  VirtualDofDeformation::surface_displacement(double *u) const
  {
    const std::vector<double> &s = interaction_.update_surface();
    std::copy(s.begin(), s.end(), u);
  }

  // ---- The rigid step, shared.

  template <class Deformation>
  FreeBody<Deformation>::FreeBody(const Model &model, const FreeBodyOptions &options)
    : options_(options)
    , tau_(model.time_step)
    , rigid_(Deformation::inertia(model))
    , undeformed_inertia_(rigid_.inertia().inertia)
    , compliance_(rigid_.step_compliance(model.time_step))
    , deformation_(model, options)
    , u_(3 * deformation_.n_vertices(), 0.0)
  {
    if (!options.gravity.allFinite())
      throw InputError("free body: gravity must be finite");
    for (auto &f : world_force_)
      f.setZero();
    rigid_.set_load(rigid_.inertia().mass * options.gravity, Eigen::Vector3d::Zero()); // t = 0
  }

  template <class Deformation>
  bool
  FreeBody<Deformation>::step(const PlaneTarget *world_planes, const int n_planes,
                              const AppliedForce *forces, const int n_forces)
  {
    if (n_planes < 0 || n_planes > contact::max_planes || n_forces < 0 ||
        n_forces > max_point_forces || (n_forces > 0 && !forces))
      return false;
    for (int a = 0; a < n_forces; ++a)
      if (forces[a].vertex >= deformation_.n_vertices() ||
          deformation_.input_vertex(forces[a].vertex) < 0 || !vec(forces[a].force).allFinite())
        return false;
    // The deformation's own angular momentum and second-order inertia at the step's start;
    // the rigid step holds h at the step's middle, extrapolated from the last two steps' (held
    // at the start, its share of the turn would be first order in the step).
    Eigen::Vector3d h  = Eigen::Vector3d::Zero();
    Eigen::Matrix3d I2 = Eigen::Matrix3d::Zero();
    if (options_.deformation_momentum)
      deformation_.second_order_momentum(h, I2);
    rigid_.set_deformation_momentum(started_inertia_ ? Eigen::Vector3d(1.5 * h - 0.5 * previous_momentum_) : h);
    // The deformed body's inertia (its mass moved by the deformation at the step's start),
    // in the rigid step and in its compliance.
    if (options_.deformed_inertia)
      {
        // A deformation too large for the truncated inertia (a moment that is not
        // positive) takes the largest share of its inertia change, halved until every moment
        // is, so that the step is limited rather than refused; such steps are counted.
        const Eigen::Matrix3d change = deformation_.inertia_change() + I2;
        inertia_share_               = 1;
        int halvings                 = 0;
        while (!rigid_.set_inertia(undeformed_inertia_ + inertia_share_ * change))
          {
            if (inertia_share_ == 0)
              return false; // the undeformed inertia itself refused: not a body
            inertia_share_ = ++halvings < 30 ? 0.5 * inertia_share_ : 0;
          }
        limited_steps_ += inertia_share_ < 1;
        compliance_ = rigid_.step_compliance(tau_);
      }
    if (!started_) // the spin of the initial state loads the deformation from t = 0
      {
        deformation_.start(rigid_.rotation().transpose() * rigid_.angular_velocity());
        started_ = true;
      }
    const RigidBodyState   start  = rigid_.state();
    const Eigen::Vector3d  weight = rigid_.inertia().mass * options_.gravity;
    const Eigen::Vector3d &center = rigid_.inertia().center;
    // 1. Where the step takes the body with no contact, and the planes in that frame.
    rigid_.step(weight, Eigen::Vector3d::Zero(), tau_);
    const Eigen::Matrix3d R  = rigid_.rotation();
    const Eigen::Vector3d c1 = rigid_.state().position;
    {
      // The frame's motion at the step's end, model frame: the angular acceleration from
      // Euler's equations with the last step's contact torque. With the deformed inertia, the
      // spin at the step's end is that of the inertia there, extrapolated from the last two
      // steps' (the rigid step holds the step start's), so that the spin's loads on the
      // deformation do not lag it by a step.
      Eigen::Matrix3d I  = rigid_.inertia().inertia;
      Eigen::Vector3d h1 = h;
      if (started_inertia_)
        I = 2 * I - previous_inertia_, h1 = 2 * h - previous_momentum_;
      previous_inertia_  = rigid_.inertia().inertia;
      previous_momentum_ = h;
      started_inertia_   = options_.deformed_inertia || options_.deformation_momentum;
      const Eigen::Vector3d omega = I.ldlt().solve(R.transpose() * rigid_.state().angular_momentum - h1);
      deformation_.set_frame_motion(omega, I.ldlt().solve(contact_torque_ - omega.cross(I * omega + h1)));
    }
    for (int p = 0; p < n_planes; ++p)
      {
        body_planes_[p]        = world_planes[p];
        body_planes_[p].normal = arr(R.transpose() * vec(world_planes[p].normal));
        body_planes_[p].point  = arr(center + R.transpose() * (vec(world_planes[p].point) - c1));
      }
    for (int a = 0; a < n_forces; ++a)
      {
        body_forces_[a].input_vertex = static_cast<unsigned>(deformation_.input_vertex(forces[a].vertex));
        body_forces_[a].force        = arr(R.transpose() * vec(forces[a].force));
      }
    // 2. The contact, rigid compliance and known forces included.
    if (!deformation_.step(body_planes_.data(), n_planes, compliance_, body_forces_.data(), n_forces))
      {
        rigid_.set_state(start);
        return false;
      }
    // 3. Net force and torque of the contact and the known forces (the modal kind's pushed
    // inputs hold both), then the rigid step again with them.
    Eigen::Vector3d force, torque;
    deformation_.contact_wrench(center, force, torque);
    for (int p = 0; p < n_planes; ++p)
      world_force_[p] = R * deformation_.plane_force(p);
    contact_torque_ = torque;
    rigid_.set_state(start);
    rigid_.step(weight + R * force, R * torque, tau_);
    return true;
  }

  template <class Deformation>
  double
  FreeBody<Deformation>::energy() const
  {
    if (!options_.deformed_inertia && !options_.deformation_momentum)
      return rigid_.kinetic_energy() + deformation_.elastic_energy();
    // The rigid body holds the inertia and h of the last step's start; the spin's energy is
    // that of the deformation now: 1/2 l^T I^-1 l - 1/2 h^T I^-1 h (RigidBody::kinetic_energy).
    Eigen::Vector3d h;
    Eigen::Matrix3d I2;
    deformation_.second_order_momentum(h, I2);
    if (!options_.deformation_momentum)
      h.setZero(), I2.setZero();
    const RigidBodyState &s = rigid_.state();
    const Eigen::Vector3d l = rigid_.rotation().transpose() * s.angular_momentum; // model frame
    const Eigen::Matrix3d I =
      options_.deformed_inertia ? Eigen::Matrix3d(undeformed_inertia_ + inertia_share_ * (deformation_.inertia_change() + I2))
                                : rigid_.inertia().inertia;
    const auto solve = I.ldlt();
    return 0.5 * s.linear_momentum.squaredNorm() / rigid_.inertia().mass +
           0.5 * l.dot(solve.solve(l)) - 0.5 * h.dot(solve.solve(h)) + deformation_.elastic_energy();
  }

  template <class Deformation>
  void
  FreeBody<Deformation>::surface_positions(double *x) const
  {
    deformation_.surface_displacement(u_.data());
    const Eigen::Matrix3d &R = rigid_.rotation();
    const Eigen::Vector3d  c = rigid_.state().position, c0 = rigid_.inertia().center;
    for (unsigned v = 0; v < deformation_.n_vertices(); ++v)
      {
        const Eigen::Vector3d X = vec(deformation_.rest_position(v));
        const Eigen::Vector3d p = c + R * (X - c0 + Eigen::Vector3d(u_[3 * v], u_[3 * v + 1], u_[3 * v + 2]));
        for (int d = 0; d < 3; ++d)
          x[3 * v + d] = p(d);
      }
  }

  template class FreeBody<ModalDeformation>;
  template class FreeBody<VirtualDofDeformation>;
} // namespace irdm
