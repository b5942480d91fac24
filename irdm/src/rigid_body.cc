// Rigid-body motion of a free body: half kicks around the free rigid body by the splitting of
// Dullweber, Leimkuhler and McLachlan (irdm/rigid_body.h).
#include <irdm/rigid_body.h>
#include <irdm_common/error.h>

#include <cmath>
#include <string>

namespace irdm
{
  namespace
  {
    // Principal axes (right-handed columns) and moments of a symmetric inertia tensor; false
    // if a moment is not positive, or, with `of_a_body`, if the moments are not those of a
    // body: every real mass distribution has I_a + I_b >= I_c (the moments are sums of
    // squared distances); round-off of a thin body is allowed.
    bool
    principal_frame(const Eigen::Matrix3d &inertia, Eigen::Matrix3d &axes, Eigen::Vector3d &moments,
                    const bool of_a_body)
    {
      // Fixed size: no allocation. The iterative solver, not computeDirect's closed form,
      // which loses digits when two moments are close (a body of revolution).
      const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(inertia);
      moments = eig.eigenvalues();
      axes    = eig.eigenvectors();
      if (axes.determinant() < 0)
        axes.col(2) *= -1;
      const double tol = 1e-9 * moments.sum();
      return moments.allFinite() && moments.minCoeff() > 0 &&
             (!of_a_body || moments(0) + moments(1) >= moments(2) - tol);
    }
  } // namespace

  RigidBody::RigidBody(const RigidBodyInertia &inertia)
    : inertia_(inertia)
  {
    const auto finite = [](const auto &m) { return m.array().isFinite().all(); };
    if (!(inertia.mass > 0) || !std::isfinite(inertia.mass) || !finite(inertia.center) ||
        !finite(inertia.inertia))
      throw InputError("rigid body: the mass must be positive and the centre and inertia "
                       "finite (mass " + std::to_string(inertia.mass) + " kg)");
    const Eigen::Matrix3d sym = 0.5 * (inertia.inertia + inertia.inertia.transpose());
    if ((sym - inertia.inertia).norm() > 1e-12 * sym.norm())
      throw InputError("rigid body: the inertia tensor is not symmetric");
    if (!principal_frame(sym, axes_, principal_, true))
      throw InputError("rigid body: principal moments " + std::to_string(principal_(0)) + ", " +
                       std::to_string(principal_(1)) + ", " + std::to_string(principal_(2)) +
                       " kg m^2 are not those of a body");
    inverse_inertia_ = axes_ * principal_.cwiseInverse().asDiagonal() * axes_.transpose();
    state_.position  = inertia.center;
    rotation_        = Eigen::Matrix3d::Identity();
  }

  bool
  RigidBody::set_inertia(const Eigen::Matrix3d &inertia)
  {
    const Eigen::Matrix3d sym = 0.5 * (inertia + inertia.transpose());
    Eigen::Matrix3d       axes;
    Eigen::Vector3d       moments;
    // Positive moments only: a first-order deformed inertia (FreeBodyOptions::
    // deformed_inertia) leaves out sum m u u^T, so a large deformation can break the triangle
    // inequality while the spin's energy 1/2 L^T I^-1 L stays well defined.
    if (!sym.allFinite() || !principal_frame(sym, axes, moments, false))
      return false;
    inertia_.inertia = sym;
    axes_            = axes;
    principal_       = moments;
    inverse_inertia_ = axes_ * principal_.cwiseInverse().asDiagonal() * axes_.transpose();
    return true;
  }

  void
  RigidBody::set_state(const RigidBodyState &s)
  {
    state_             = s;
    state_.orientation = s.orientation.normalized();
    rotation_          = state_.orientation.toRotationMatrix();
  }

  void
  RigidBody::set_velocity(const Eigen::Vector3d &velocity, const Eigen::Vector3d &angular_velocity)
  {
    state_.linear_momentum = inertia_.mass * velocity;
    // L = R (I R^T omega + h)
    state_.angular_momentum =
      rotation_ * (inertia_.inertia * (rotation_.transpose() * angular_velocity) + deformation_momentum_);
  }

  Eigen::Vector3d
  RigidBody::angular_velocity() const
  {
    return rotation_ * (inverse_inertia_ * (rotation_.transpose() * state_.angular_momentum -
                                            deformation_momentum_));
  }

  double
  RigidBody::kinetic_energy() const
  {
    // With l = R^T L and omega = I^-1 (l - h): 1/2 omega^T I omega + omega . h
    // = 1/2 l^T I^-1 l - 1/2 h^T I^-1 h.
    const Eigen::Vector3d l = rotation_.transpose() * state_.angular_momentum;
    const Eigen::Vector3d h = deformation_momentum_;
    return 0.5 * state_.linear_momentum.squaredNorm() / inertia_.mass +
           0.5 * l.dot(inverse_inertia_ * l) - 0.5 * h.dot(inverse_inertia_ * h);
  }

  Eigen::Matrix3d
  RigidBody::step_compliance(const Eigen::Vector3d &X, const Eigen::Vector3d &Y,
                             const double tau) const
  {
    const auto cross = [](const Eigen::Vector3d &r) {
      Eigen::Matrix3d c;
      c << 0, -r(2), r(1), r(2), 0, -r(0), -r(1), r(0), 0;
      return c;
    };
    return 0.25 * tau * tau *
           (Eigen::Matrix3d::Identity() / inertia_.mass -
            cross(X - inertia_.center) * inverse_inertia_ * cross(Y - inertia_.center));
  }

  void
  RigidBody::rotate_about_principal_axis(const int axis, const double tau)
  {
    // The body-frame angular momentum's component along the axis is constant in this flow,
    // and h is held, so the flow is a rotation about the axis at the rate
    // (L_axis - h_axis) / I_axis.
    const Eigen::Vector3d a      = axes_.col(axis);
    const double          l_axis = a.dot(rotation_.transpose() * state_.angular_momentum - deformation_momentum_);
    const double          angle  = tau * l_axis / principal_(axis);
    state_.orientation = (state_.orientation * Eigen::Quaterniond(Eigen::AngleAxisd(angle, a)))
                           .normalized();
    rotation_ = state_.orientation.toRotationMatrix();
  }

  void
  RigidBody::step(const Eigen::Vector3d &force, const Eigen::Vector3d &torque, const double tau)
  {
    const Eigen::Vector3d dp = (0.25 * tau) * (state_.force + force);
    const Eigen::Vector3d dL = (0.25 * tau) * (state_.torque + torque);
    state_.linear_momentum += dp;
    state_.angular_momentum += dL;
    state_.position += (tau / inertia_.mass) * state_.linear_momentum;
    rotate_about_principal_axis(0, 0.5 * tau);
    rotate_about_principal_axis(1, 0.5 * tau);
    rotate_about_principal_axis(2, tau);
    rotate_about_principal_axis(1, 0.5 * tau);
    rotate_about_principal_axis(0, 0.5 * tau);
    state_.linear_momentum += dp;
    state_.angular_momentum += dL;
    state_.force  = force;
    state_.torque = torque;
  }
} // namespace irdm
