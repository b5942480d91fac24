#pragma once
// A free (non-grounded) body at run time (issue 14; shared/notes/irdm-method.md section 6):
// rigid-body dynamics (irdm/rigid_body.h) moves the body, and IRDM deforms it in its own frame.
// Units SI; impulse = force x time step, as everywhere. Two kinds of deformation and contact
// share the rigid step below (FreeBody<Deformation>):
//   FreeBodyInteraction: the modal IRDM of a free-body model from `irdm precompute` (either
//     route; irdm/modal_model.h) under many-vertex contact (irdm/vertex_contact.h);
//   FreeBodyVirtualDofs: the seed's virtual DOFs from `irdm precompute-vdof` on a free body
//     (irdm/plane_interaction.h; the nonlinear FEM's wall hits less their best rigid fit).
//
// One step of length tau, with planes (floor, walls) given in the world:
//   1. the rigid body's step without contact (gravity only) predicts the pose (c', R') at the
//      step's end; the planes are taken into the model frame by that pose;
//   2. the contact is solved in the model frame against the deformation's history, with a
//      feed-through that is the deformation's H[0] plus the rigid body's own compliance over
//      the step (RigidStepCompliance): a contact force moves the body as well as denting it,
//      both within the step;
//   3. the contact forces join the deformation's force history (model frame), and the rigid
//      body takes its step again from where it was, with gravity and the contact forces'
//      net force and torque about the centre of mass, at the contact points, turned into the
//      world by R'. A contact point is the deformed one at the step's start, X + u, both in
//      the compliance of step 2 (each row's lever) and in this torque, so that the torque acts
//      where the solve expected it to.
// The contact is exact to first order in the step's rotation (the compliance is linear in
// the torque); the pose, the momenta and the energy are the rigid body's exact integrator.
//
// What the deformation includes of the body's own motion. The elastic modes are
// mass-orthogonal to the six rigid motions, so a body force that is uniform (gravity) or
// rigid (the inertia forces of the body's linear and angular acceleration, -M a - M (alpha x
// r)) drives none of them: in the accelerating frame the deformation is driven by the contact
// forces alone, which is exact for linear elasticity. Left out by default: the centrifugal
// and Coriolis forces of the body's spin (-M omega x (omega x r), -2 M omega x v), which are
// not rigid motions; free_body_validation measures their size against the contact's. With
// FreeBodyOptions::centrifugal the modal kind takes the centrifugal force of the step's
// predicted spin into its force history (the model's /modes/centrifugal_load, from the
// precompute's full mode shapes and mass matrix): a load on the elastic modes only. With
// FreeBodyOptions::deformed_inertia the rigid body's inertia is the deformed body's (to first
// order in the deformation, from the same data), so that the spin slows as the body stretches
// and the stretch's energy is taken from the spin: the centrifugal load is the gradient of the
// spin's kinetic energy 1/2 L^T I(u)^-1 L in the deformation at fixed angular momentum, so
// the two together create no energy. FreeBodyOptions::euler, spin_softening and coriolis take
// the frame's other forces in, and deformation_momentum the deformation's own angular momentum
// in the rigid body: the linear floating-frame theory of docs/free-body.md.
//
// Virtual DOFs: the deformation is what the nonlinear FEM's free body did after a wall hit,
// less its best rigid fit, so it holds what the hit's own acceleration did to the body; the
// spin's forces are left out here as well. A virtual-DOF wall is the precompute's penalty wall
// (VirtualDofModel::wall_stiffness, a spring in series with the body) and its force acts at
// the mapped virtual DOF's band centroid (PlaneInteraction::contact_point). One force at one
// body-fixed point per plane cannot carry a resting contact's moment (a flat face rests as if
// balanced on that point) and a wall that stops the body within a step bounces it off faster
// than it came: reports/free measures where this fails. Nor can a band stand in for the body
// behind it: the cat's ear tips and the top of its head are bands of a few vertices, which
// the precompute hit with 0.03 to 0.2 N and which give 0.01 to 0.15 m per newton held (50
// kPa); landed on its head, the cat's band recedes with the floor and the body sinks through
// it (25 cm by 1.2 s into the 50 kPa roll), until the mapping turns to a stiff band that meets
// the floor that deep and throws the body off 13 J richer (it started with 0.13 J of motion):
// the 60 s roll's energy gain, and `below floor` in reports/free's stability table. The
// deformation's energy is not known from the responses: energy() is the rigid body's alone
// for this kind.
//
// Probes: known point forces (AppliedForce of irdm/irdm.h, world frame) join the contact forces in the net
// force and torque and, turned into the model frame by R', the deformation's force history;
// the contact solve sees what they do within the step. Only the modal kind takes them.
//
// Memory is sized at construction; step() allocates nothing and takes no lock.
#include <irdm/modal_model.h>
#include <irdm/plane_interaction.h>
#include <irdm/rigid_body.h>
#include <irdm/vertex_contact.h>

#include <array>
#include <vector>

namespace irdm
{
  struct FreeBodyOptions
  {
    Eigen::Vector3d      gravity = Eigen::Vector3d(0, 0, -9.81); // m/s^2, world
    VertexContactOptions contact; // FreeBodyInteraction: the many-vertex contact
    // FreeBodyVirtualDofs: how a plane maps to the dome's virtual DOFs.
    OrientationMapping mapping = OrientationMapping::nearest;
    // FreeBodyInteraction: the spin's centrifugal force on the deformation (the step's
    // predicted angular velocity; ModalInteraction::set_spin). Needs a model with
    // /modes/centrifugal_load; the constructor refuses one without.
    bool centrifugal = false;
    // FreeBodyInteraction: the rigid body's inertia is the deformed body's, I0 + dI(u) to
    // first order in the deformation (ModalInteraction::inertia_change), updated at every
    // step's start; the angular momentum is kept, so the spin slows as the body stretches and
    // quickens as it is pressed in. With `centrifugal` as well, the spin and the deformation
    // exchange energy and create none (the centrifugal load is the gradient of the spin's
    // kinetic energy in the deformation). Needs /modes/centrifugal_load, as `centrifugal`.
    bool deformed_inertia = false;
    // FreeBodyInteraction: the moving frame's other forces on the deformation
    // (ModalInteraction::set_frame_forces; docs/free-body.md): the Euler force of the frame's
    // angular acceleration, the spin softening, the Coriolis force. Need a model with
    // /modes/inertial_coupling; the constructor refuses one without.
    bool euler = false, spin_softening = false, coriolis = false;
    // FreeBodyInteraction: the rigid body's angular momentum to second order in the
    // deformation (ModalInteraction::second_order_momentum): the deformation's own angular
    // momentum h, which turns the frame at I^-1 (R^T L - h) (the Coriolis force's reaction),
    // and, with deformed_inertia, the inertia's second-order change I2. Needs
    // /modes/inertial_coupling, as the frame forces; on the same frame_modes.
    bool deformation_momentum = false;
    // The lowest modes they act on (9 frame_modes^2 multiply-adds per step); 0: every mode
    // whose couplings the model holds (within the force loop's).
    unsigned frame_modes = 0;
    bool
    frame_forces() const
    {
      return euler || spin_softening || coriolis;
    }
  };

  /// The modal deformation under many-vertex contact (FreeBodyInteraction's).
  class ModalDeformation
  {
  public:
    using Model = ModalModel;
    /// Throws InputError if the model is not of a free body (ModelFrame::free_body).
    ModalDeformation(const ModalModel &model, const FreeBodyOptions &options);
    static RigidBodyInertia
    inertia(const ModalModel &model);
    double
    time_step() const
    {
      return model_.time_step;
    }
    /// The contact of up to contact::max_planes planes (model frame) with the rigid
    /// compliance in its feed-through, and known forces (model frame, input vertices).
    bool
    step(const PlaneTarget *body_planes, int n_planes, const RigidStepCompliance &rigid,
         const InputForce *applied, int n_applied);
    /// The spin (rad/s, model frame) whose centrifugal force loads the next steps, if
    /// FreeBodyOptions::centrifugal.
    /// The frame's angular velocity and acceleration at the next step's end (rad/s, rad/s^2,
    /// model frame): the centrifugal load and the frame forces the options turn on.
    void
    set_frame_motion(const Eigen::Vector3d &omega, const Eigen::Vector3d &alpha)
    {
      if (centrifugal_)
        interaction_.set_spin(omega);
      interaction_.set_frame_motion(omega, alpha);
    }
    /// Before the first step: the spin at t = 0 (rad/s, model frame) loads the deformation
    /// from the start (ModalInteraction::load_from_start).
    void
    start(const Eigen::Vector3d &omega)
    {
      if (centrifugal_)
        {
          interaction_.set_spin(omega);
          interaction_.load_from_start();
        }
    }
    /// The deformed body's inertia less the undeformed one (ModalInteraction::inertia_change).
    Eigen::Matrix3d
    inertia_change() const
    {
      return interaction_.inertia_change();
    }
    /// h and I2 (ModalInteraction::second_order_momentum).
    void
    second_order_momentum(Eigen::Vector3d &h, Eigen::Matrix3d &I2) const
    {
      interaction_.second_order_momentum(h, I2);
    }
    /// The input vertex of surface vertex v, or -1 (no force can be applied there).
    int
    input_vertex(unsigned v) const
    {
      return model_.output_input_index[v];
    }
    /// Net force and torque about `center` of the latest step's contact (model frame), at the
    /// deformed contact points (a contact row's at the step's start, where the solve took its
    /// lever; a known force's after the step).
    void
    contact_wrench(const Eigen::Vector3d &center, Eigen::Vector3d &force, Eigen::Vector3d &torque);
    Eigen::Vector3d
    plane_force(int p) const; // N, model frame
    const PlaneContactResult &
    plane_result(int p) const
    {
      return interaction_.vertex_contact().plane(p);
    }
    unsigned
    n_vertices() const
    {
      return model_.n_outputs / 3;
    }
    const std::array<double, 3> &
    rest_position(unsigned v) const
    {
      return model_.output_coordinates[v];
    }
    /// Displacement of every output vertex (m, model frame, 3 per vertex).
    void
    surface_displacement(double *u) const
    {
      interaction_.surface_displacement(u);
    }
    double
    elastic_energy() const
    {
      return interaction_.elastic_energy();
    }
    const ModalInteraction &
    interaction() const
    {
      return interaction_;
    }

  private:
    const ModalModel &model_;
    ModalInteraction  interaction_;
    std::vector<char> vertex_done_; // [input vertex], scratch
    bool              centrifugal_;
  };

  /// The seed's virtual DOFs of a free body (FreeBodyVirtualDofs').
  class VirtualDofDeformation
  {
  public:
    using Model = VirtualDofModel;
    /// Throws InputError if the model is not of a free body (VirtualDofModel::free_body).
    VirtualDofDeformation(const VirtualDofModel &model, const FreeBodyOptions &options);
    static RigidBodyInertia
    inertia(const VirtualDofModel &model);
    double
    time_step() const
    {
      return model_.time_step;
    }
    /// The frame's forces are not in the model (header): a no-op.
    void
    set_frame_motion(const Eigen::Vector3d &, const Eigen::Vector3d &)
    {}
    void
    start(const Eigen::Vector3d &)
    {}
    /// The mode shapes are not in the model: the constructor refuses
    /// FreeBodyOptions::deformed_inertia, and this is never called with it.
    Eigen::Matrix3d
    inertia_change() const
    {
      return Eigen::Matrix3d::Zero();
    }
    /// Likewise (FreeBodyOptions::deformation_momentum is refused): zero.
    void
    second_order_momentum(Eigen::Vector3d &h, Eigen::Matrix3d &I2) const
    {
      h.setZero();
      I2.setZero();
    }
    /// Up to PlaneInteraction::max_walls walls, as stiff as the precompute's (a plane's own
    /// stiffness is not used). Known point forces are refused (false): the model holds
    /// responses to walls only.
    bool
    step(const PlaneTarget *body_planes, int n_planes, const RigidStepCompliance &rigid,
         const InputForce *applied, int n_applied);
    int
    input_vertex(unsigned) const
    {
      return -1;
    }
    void
    contact_wrench(const Eigen::Vector3d &center, Eigen::Vector3d &force, Eigen::Vector3d &torque);
    Eigen::Vector3d
    plane_force(int p) const; // N, model frame
    unsigned
    n_vertices() const
    {
      return model_.n_surface;
    }
    const std::array<double, 3> &
    rest_position(unsigned v) const
    {
      return model_.coordinates[v];
    }
    /// The surface convolution (PlaneInteraction::update_surface): costs the active virtual
    /// DOFs x T x surface; the seed runs it at the display rate, not every force step.
    void
    surface_displacement(double *u) const;
    /// Not known from the responses (header): 0.
    double
    elastic_energy() const
    {
      return 0;
    }
    const PlaneInteraction &
    interaction() const
    {
      return interaction_;
    }

  private:
    const VirtualDofModel &model_;
    // update_surface() fills the interaction's own buffer: a cache, not the body's state.
    mutable PlaneInteraction interaction_;
    int                      n_walls_ = 0;
    std::array<double, PlaneInteraction::max_walls> force_{}; // N, along -d
  };

  /// A free body: the rigid step above with a deformation kind (ModalDeformation,
  /// VirtualDofDeformation). Instantiated for those two in free_body.cc.
  template <class Deformation>
  class FreeBody
  {
  public:
    using Model = typename Deformation::Model;
    /// Throws InputError if the model is not of a free body.
    FreeBody(const Model &model, const FreeBodyOptions &options = {});

    /// The rigid motion; set its pose and velocity before the first step (it starts at the
    /// model frame's pose, at rest).
    RigidBody &
    rigid()
    {
      return rigid_;
    }
    const RigidBody &
    rigid() const
    {
      return rigid_;
    }
    /// The deformation in the model frame.
    const Deformation &
    deformation() const
    {
      return deformation_;
    }

    static constexpr int max_point_forces = 16;

    /// One step with up to contact::max_planes planes in the world frame (PlaneTarget: unit
    /// normal toward the body, a point of the plane at the step's end; stiffness as there)
    /// and up to max_point_forces known point forces (probes). Returns false (no step taken)
    /// if the contact cannot be solved or a point force cannot be applied (a vertex out of
    /// range or not an input of the model; the virtual-DOF kind takes none).
    bool
    step(const PlaneTarget *world_planes, int n_planes, const AppliedForce *forces = nullptr,
         int n_forces = 0);

    /// Force of plane p on the body at the latest step (N, world).
    Eigen::Vector3d
    plane_force(int p) const
    {
      return world_force_[p];
    }
    /// World position of every surface vertex (3 per vertex, m): the deformed surface placed
    /// by the rigid pose. Allocates nothing.
    void
    surface_positions(double *x) const;
    /// Rigid kinetic energy plus the deformation's energy (J); with gravity g, add
    /// -m g . c for the potential. With FreeBodyOptions::deformed_inertia the spin's energy
    /// is 1/2 L^T I(u)^-1 L with the deformation as it is now.
    double
    energy() const;
    double
    time_step() const
    {
      return tau_;
    }
    /// Steps whose deformed inertia (FreeBodyOptions::deformed_inertia) was limited: the
    /// deformation was too large for the first-order inertia to keep every moment positive,
    /// so the step took the largest share of the inertia change that did (halving it).
    unsigned long
    limited_steps() const
    {
      return limited_steps_;
    }

  private:
    FreeBodyOptions                                  options_;
    double                                           tau_;
    RigidBody                                        rigid_;
    Eigen::Matrix3d                                  undeformed_inertia_; // model frame
    RigidStepCompliance                              compliance_;
    Deformation                                      deformation_;
    std::array<PlaneTarget, contact::max_planes>     body_planes_{};
    std::array<InputForce, max_point_forces>       body_forces_{};
    std::array<Eigen::Vector3d, contact::max_planes> world_force_{};
    mutable std::vector<double>                      u_; // surface displacement, model frame
    Eigen::Vector3d contact_torque_ = Eigen::Vector3d::Zero(); // the last step's, model frame
    bool            started_        = false; // a step was taken
    // The deformed inertia of the last step (model frame), for the extrapolation to the
    // step's end; started_inertia_: it is set.
    Eigen::Matrix3d previous_inertia_ = Eigen::Matrix3d::Zero();
    Eigen::Vector3d previous_momentum_ = Eigen::Vector3d::Zero(); // h, likewise
    bool            started_inertia_  = false;
    double          inertia_share_    = 1; // of the deformed inertia's change, this step
    unsigned long   limited_steps_    = 0;
  };

  using FreeBodyInteraction = FreeBody<ModalDeformation>;
  using FreeBodyVirtualDofs = FreeBody<VirtualDofDeformation>;
} // namespace irdm
