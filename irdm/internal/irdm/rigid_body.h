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
// Integrator. Forces are samples at the ends of steps, as the FEM's loads: a step of length
// tau from t_n to t_n+1 with the force F and torque t (about the centre of mass, world) at
// t_n+1, the state holding those at t_n. Half the step's trapezoidal impulse, the free body
// over the step, the other half:
//   kick   p += tau/4 (F_n + F_n+1),  L += tau/4 (t_n + t_n+1)    (world momenta)
//   drift  c += tau p / m,  R <- R exp(tau ...)                    (the free rigid body)
//   kick   p += tau/4 (F_n + F_n+1),  L += tau/4 (t_n + t_n+1)
// For the translation this is exactly the FEM's average-acceleration Newmark (beta = 1/4,
// gamma = 1/2): c_n+1 = c_n + tau v_n + tau^2/4 (a_n + a_n+1), v_n+1 = v_n + tau/2 (a_n +
// a_n+1). So a free body's IRDM reproduces the linear FEM of the free body in translation
// (the FEM's own rigid modes), and a force at t_n+1 moves the body by tau^2 / 4m within its
// step: the rigid share of the contact feed-through (step_compliance). A model made with
// generalized-alpha (rho_inf < 1) has elastic modes integrated by that scheme and rigid motion
// by this one (they agree to second order in tau).
// The free rotation is the splitting of Dullweber, Leimkuhler and McLachlan (J. Chem. Phys.
// 107, 5840, 1997): the kinetic energy L1^2/2I1 + L2^2/2I2 + L3^2/2I3 (principal axes) is split
// into its three terms, each of whose flows is an exact rotation about one principal axis, and
// they are composed symmetrically (1/2, 2/2, 3, 2/2, 1/2 of the step). Each substep rotates the
// orientation and leaves the world angular momentum unchanged, so with no force or torque p
// and L stay exactly what they were (zero kicks), the composition is symplectic and
// time-reversible, so the energy error stays bounded (no drift) and the orientation is second
// order in tau. The orientation is a unit quaternion, renormalized after every substep.
#include <Eigen/Dense>
#include <Eigen/Geometry>

#include <array>

namespace irdm
{
  /// A 3-vector between the model files' arrays and Eigen.
  inline Eigen::Vector3d
  vec(const std::array<double, 3> &a)
  {
    return {a[0], a[1], a[2]};
  }
  inline std::array<double, 3>
  arr(const Eigen::Vector3d &v)
  {
    return {v(0), v(1), v(2)};
  }

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
    Eigen::Vector3d    force  = Eigen::Vector3d::Zero(); // N, world, the load at this time
    Eigen::Vector3d    torque = Eigen::Vector3d::Zero(); // N m, world, about c
  };

  /// The rigid body's own compliance over one step, the part of the contact feed-through a
  /// free body adds to its deformation's H[0] (RigidBody::step_compliance; model frame): the
  /// displacement of model-frame point X, per newton on point Y, after one step,
  ///   tau^2/4 (I / m + [X - c]x^T I^-1 [Y - c]x)     (I the model-frame inertia about c).
  struct RigidStepCompliance
  {
    double          tau2_over_mass = 0;                            // m/N: tau^2 / 4m
    Eigen::Matrix3d tau2_inverse_inertia = Eigen::Matrix3d::Zero(); // tau^2/4 I^-1, 1/(N m)
    Eigen::Vector3d center = Eigen::Vector3d::Zero();              // m

    /// Entry (a, b): along axis a at X per newton along axis b at Y.
    double
    entry(const Eigen::Vector3d &X, int a, const Eigen::Vector3d &Y, int b) const
    {
      const Eigen::Vector3d ra = (X - center).cross(Eigen::Vector3d::Unit(a));
      const Eigen::Vector3d rb = (Y - center).cross(Eigen::Vector3d::Unit(b));
      return (a == b ? tau2_over_mass : 0.0) + ra.dot(tau2_inverse_inertia * rb);
    }
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

    /// The load at the present time (a body released under gravity: its weight at t = 0).
    void
    set_load(const Eigen::Vector3d &force, const Eigen::Vector3d &torque)
    {
      state_.force  = force;
      state_.torque = torque;
    }
    /// The inertia tensor (model frame, about the centre of mass) from now on: a deformed
    /// body's, I0 + dI(q) (FreeBodyOptions::deformed_inertia). The angular momentum is kept,
    /// so the spin changes as the body's mass moves in or out (a skater's pull-in). Returns
    /// false and changes nothing if a principal moment is not positive and finite (the
    /// triangle inequality of a real body is not asked: a first-order deformed inertia can
    /// break it). Allocates nothing.
    bool
    set_inertia(const Eigen::Matrix3d &inertia);
    /// The deformation's own angular momentum h (N m s, model frame, about the centre of
    /// mass) from now on: the body's is then R (I omega + h), so that the frame turns at
    /// omega = I^-1 (R^T L - h) (a gyrostat; docs/free-body.md). The drift holds it over a
    /// step; each of its rotations stays exact. Zero by default.
    void
    set_deformation_momentum(const Eigen::Vector3d &h)
    {
      deformation_momentum_ = h;
    }
    const Eigen::Vector3d &
    deformation_momentum() const
    {
      return deformation_momentum_;
    }
    /// One step of length tau to a time where the load is force and torque (kick, drift, kick;
    /// see above). Allocates nothing.
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
    /// omega = R I^-1 (R^T L - h) (world).
    Eigen::Vector3d
    angular_velocity() const;
    /// J: 1/2 p.p / m + 1/2 omega^T I omega + omega . h (R^T omega, model frame), the kinetic
    /// energy of the body but for the deformation's own, 1/2 |q'|^2.
    double
    kinetic_energy() const;
    const RigidBodyInertia &
    inertia() const
    {
      return inertia_;
    }
    /// Displacement (model frame) of model-frame point X after one step of length tau, per
    /// newton of a model-frame force on model-frame point Y at the step's end, to first order
    /// in the force: tau^2/4 (I / m - [X - c]x I^-1 [Y - c]x), I the model-frame inertia. The
    /// rigid body's share of the contact feed-through (its own compliance within a step).
    Eigen::Matrix3d
    step_compliance(const Eigen::Vector3d &X, const Eigen::Vector3d &Y, double tau) const;
    /// The same as a value the contact solve evaluates entry by entry.
    RigidStepCompliance
    step_compliance(double tau) const
    {
      const double b = 0.25 * tau * tau; // Newmark's beta tau^2
      return {b / inertia_.mass, b * inverse_inertia_, inertia_.center};
    }

  private:
    RigidBodyInertia   inertia_;
    Eigen::Matrix3d    axes_;          // principal axes in the model frame (columns)
    Eigen::Vector3d    principal_;     // principal moments, kg m^2
    Eigen::Matrix3d    inverse_inertia_; // model frame
    RigidBodyState     state_;
    Eigen::Matrix3d    rotation_;      // of state_.orientation
    Eigen::Vector3d    deformation_momentum_ = Eigen::Vector3d::Zero(); // h, model frame

    // R <- R exp(theta [axes_ e_axis]x): the exact flow of (L_axis - h_axis)^2 / 2 I_axis for
    // tau.
    void
    rotate_about_principal_axis(int axis, double tau);
  };
} // namespace irdm
