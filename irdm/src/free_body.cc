// A free body at run time: rigid motion and deformation in the body frame (irdm/free_body.h).
#include <irdm/free_body.h>
#include <irdm_common/error.h>

namespace irdm
{
  namespace
  {
    RigidBodyInertia
    inertia_of(const ModelFrame &m)
    {
      if (!m.free_body)
        throw InputError("free body: the model is of a grounded body (it has a fixed surface); "
                         "precompute a scene with no fixed surface");
      RigidBodyInertia in;
      in.mass = m.mass;
      for (int i = 0; i < 3; ++i)
        {
          in.center(i) = m.center_of_mass[i];
          for (int j = 0; j < 3; ++j)
            in.inertia(i, j) = m.inertia[i][j];
        }
      return in;
    }

    Eigen::Vector3d
    vec(const std::array<double, 3> &a)
    {
      return {a[0], a[1], a[2]};
    }
    std::array<double, 3>
    arr(const Eigen::Vector3d &v)
    {
      return {v(0), v(1), v(2)};
    }
  } // namespace

  FreeBodyInteraction::FreeBodyInteraction(const ModalModel &model, const FreeBodyOptions &options)
    : model_(model)
    , options_(options)
    , tau_(model.time_step)
    , rigid_(inertia_of(model))
    , compliance_(rigid_.step_compliance(model.time_step))
    , deformation_(model, options.contact)
    , u_(model.n_outputs, 0.0)
    , vertex_done_(model.n_inputs / 3, 0)
  {
    if (!options.gravity.allFinite())
      throw InputError("free body: gravity must be finite");
    for (auto &f : world_force_)
      f.setZero();
    rigid_.set_load(rigid_.inertia().mass * options.gravity, Eigen::Vector3d::Zero()); // t = 0
  }

  bool
  FreeBodyInteraction::step(const PlaneTarget *world_planes, const int n_planes)
  {
    if (n_planes < 0 || n_planes > contact::max_planes)
      return false;
    const RigidBodyState  start   = rigid_.state();
    const Eigen::Vector3d weight  = rigid_.inertia().mass * options_.gravity;
    const Eigen::Vector3d &center = rigid_.inertia().center;
    // 1. Where the step takes the body with no contact, and the planes in that frame.
    rigid_.step(weight, Eigen::Vector3d::Zero(), tau_);
    const Eigen::Matrix3d R  = rigid_.rotation();
    const Eigen::Vector3d c1 = rigid_.state().position;
    for (int p = 0; p < n_planes; ++p)
      {
        body_planes_[p]        = world_planes[p];
        body_planes_[p].normal = arr(R.transpose() * vec(world_planes[p].normal));
        body_planes_[p].point  = arr(center + R.transpose() * (vec(world_planes[p].point) - c1));
      }
    // 2. The contact, rigid compliance included.
    if (!deformation_.step(body_planes_.data(), n_planes, compliance_))
      {
        rigid_.set_state(start);
        return false;
      }
    // 3. Net force and torque of the contact at the deformed points (model frame), then the
    // rigid step again with them.
    Eigen::Vector3d force = Eigen::Vector3d::Zero(), torque = Eigen::Vector3d::Zero();
    for (const unsigned k : deformation_.pushed_inputs())
      {
        const unsigned vertex = k / 3;
        if (vertex_done_[vertex])
          continue; // its three DoFs are taken together
        vertex_done_[vertex] = 1;
        Eigen::Vector3d f, r = vec(model_.output_coordinates[model_.input_output_index[vertex]]) - center;
        for (int d = 0; d < 3; ++d)
          {
            f(d) = deformation_.force_on_input(3 * vertex + d);
            r(d) += deformation_.input_displacement(3 * vertex + d);
          }
        force += f;
        torque += r.cross(f);
      }
    for (const unsigned k : deformation_.pushed_inputs())
      vertex_done_[k / 3] = 0;
    for (int p = 0; p < n_planes; ++p)
      world_force_[p] = R * vec(deformation_.vertex_contact().plane(p).force);
    rigid_.set_state(start);
    rigid_.step(weight + R * force, R * torque, tau_);
    return true;
  }

  void
  FreeBodyInteraction::surface_positions(double *x) const
  {
    deformation_.surface_displacement(u_.data());
    const Eigen::Matrix3d &R = rigid_.rotation();
    const Eigen::Vector3d  c = rigid_.state().position, c0 = rigid_.inertia().center;
    for (unsigned v = 0; v < model_.n_outputs / 3; ++v)
      {
        const Eigen::Vector3d X = vec(model_.output_coordinates[v]);
        const Eigen::Vector3d p = c + R * (X - c0 + Eigen::Vector3d(u_[3 * v], u_[3 * v + 1], u_[3 * v + 2]));
        for (int d = 0; d < 3; ++d)
          x[3 * v + d] = p(d);
      }
  }
} // namespace irdm
