#pragma once
// The rigid motion of a free (non-grounded) body: seed 001 splits each response of a free body
// into rigid motion and deformation (shared/notes/irdm-method.md section 6); at run time the
// motion comes from rigid-body dynamics (here) and the deformation from IRDM, in the body's
// frame. Units SI.
//
// Frames. The model frame is the mesh's: the undeformed body, its centre of mass at
// `center`. A body pose (c, R) places a model-frame point X (displaced by u in the model
// frame) at x = c + R (X - center + u) in the world.
//
// Integrator. A step of length tau with a force F and a torque t (about the centre of mass,
// world frame) held during the step, the IRDM convention (impulse = force x tau):
//   kick   p += F tau,  L += t tau                       (world linear / angular momentum)
//   drift  c += tau p / m,  R <- R exp(tau ...)          (the free rigid body over tau)
// The free rotation is the splitting of Dullweber, Leimkuhler and McLachlan (J. Chem. Phys.
// 107, 5840, 1997): the kinetic energy L1^2/2I1 + L2^2/2I2 + L3^2/2I3 (principal axes) is split
// into its three terms, each of whose flows is an exact rotation about one principal axis, and
// they are composed symmetrically (1/2, 2/2, 3, 2/2, 1/2 of the step). Each substep rotates the
// orientation and leaves the world angular momentum unchanged, so with no torque L stays
// exactly what it was (it is never written), p likewise; the composition is symplectic and
// time-reversible, so the energy error stays bounded (no drift) and the orientation is second
// order in tau. The orientation is a unit quaternion, renormalized after every substep.
#include <Eigen/Dense>
#include <Eigen/Geometry>

namespace irdm
{
  /// Mass properties of the undeformed body in the model frame.
  struct RigidBodyInertia
  {
    double          mass = 0;                          // kg
    Eigen::Vector3d center  = Eigen::Vector3d::Zero(); // m, centre of mass
    Eigen::Matrix3d inertia = Eigen::Matrix3d::Zero(); // kg m^2, about the centre of mass
  };

  struct RigidBodyState
  {
    Eigen::Vector3d    position = Eigen::Vector3d::Zero(); // m, centre of mass, world
    Eigen::Quaterniond orientation = Eigen::Quaterniond::Identity(); // model frame -> world
    Eigen::Vector3d    linear_momentum  = Eigen::Vector3d::Zero(); // N s, world
    Eigen::Vector3d    angular_momentum = Eigen::Vector3d::Zero(); // N m s, world, about c
  };

  class RigidBody
  {
  public:
    /// Throws InputError for a mass or principal moment that is not positive and finite, or
    /// moments that break the triangle inequality (no real body has them).
    explicit RigidBody(const RigidBodyInertia &inertia);

    /// Starts at the model frame's pose (centre of mass at `center`, no rotation), at rest.
    const RigidBodyState &
    state() const
    {
      return state_;
    }
    void
    set_state(const RigidBodyState &s);
    /// Sets the momenta from a velocity of the centre of mass and an angular velocity (world).
    void
    set_velocity(const Eigen::Vector3d &velocity, const Eigen::Vector3d &angular_velocity);

    /// One step of length tau (kick, then drift; see above). Allocates nothing.
    void
    step(const Eigen::Vector3d &force, const Eigen::Vector3d &torque, double tau);

    /// World position of the model-frame point X displaced by u (model frame).
    Eigen::Vector3d
    to_world(const Eigen::Vector3d &X, const Eigen::Vector3d &u = Eigen::Vector3d::Zero()) const
    {
      return state_.position + rotation_ * (X - inertia_.center + u);
    }
    /// World rotation matrix R (model frame -> world).
    const Eigen::Matrix3d &
    rotation() const
    {
      return rotation_;
    }
    Eigen::Vector3d
    velocity() const
    {
      return state_.linear_momentum / inertia_.mass;
    }
    /// omega = R I^-1 R^T L (world).
    Eigen::Vector3d
    angular_velocity() const;
    /// J: 1/2 p.p / m + 1/2 L . omega.
    double
    kinetic_energy() const;
    const RigidBodyInertia &
    inertia() const
    {
      return inertia_;
    }
    /// Displacement (model frame) of model-frame point X after one step of length tau, per
    /// newton of a model-frame force on model-frame point Y, to first order in the force:
    /// tau^2 (I / m - [X - c]x I^-1 [Y - c]x), I the model-frame inertia. The rigid body's
    /// share of the contact feed-through (its own compliance within a step).
    Eigen::Matrix3d
    step_compliance(const Eigen::Vector3d &X, const Eigen::Vector3d &Y, double tau) const;

  private:
    RigidBodyInertia   inertia_;
    Eigen::Matrix3d    axes_;          // principal axes in the model frame (columns)
    Eigen::Vector3d    principal_;     // principal moments, kg m^2
    Eigen::Matrix3d    inverse_inertia_; // model frame
    RigidBodyState     state_;
    Eigen::Matrix3d    rotation_;      // of state_.orientation

    // R <- R exp(theta [axes_ e_axis]x): the exact flow of L_axis^2 / 2 I_axis for tau.
    void
    rotate_about_principal_axis(int axis, double tau);
  };
} // namespace irdm
