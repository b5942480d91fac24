#pragma once
// A free (non-grounded) body at run time (issue 14; shared/notes/irdm-method.md section 6):
// rigid-body dynamics (irdm/rigid_body.h) moves the body, and the modal IRDM of a free-body
// model (irdm/modal_model.h; its six rigid-body modes removed by the precompute) deforms it in
// its own frame. Units SI; impulse = force x time step, as everywhere.
//
// One step of length tau, with planes (floor, walls) given in the world:
//   1. the rigid body's step without contact (gravity only) predicts the pose (c', R') at the
//      step's end; the planes are taken into the model frame by that pose;
//   2. the many-vertex contact (irdm/vertex_contact.h) is solved in the model frame against
//      the deformation's history, with a feed-through that is the deformation's H[0] plus
//      the rigid body's own compliance over the step (RigidStepCompliance): a contact force
//      moves the body as well as denting it, both within the step;
//   3. the contact forces join the deformation's force history (model frame), and the rigid
//      body takes its step again from where it was, with gravity and the contact forces'
//      net force and torque about the centre of mass, at the deformed contact points, turned
//      into the world by R'.
// The contact is exact to first order in the step's rotation (the compliance is linear in
// the torque); the pose, the momenta and the energy are the rigid body's exact integrator.
//
// What the deformation includes of the body's own motion. The elastic modes are
// mass-orthogonal to the six rigid motions, so a body force that is uniform (gravity) or
// rigid (the inertia forces of the body's linear and angular acceleration, -M a - M (alpha x
// r)) drives none of them: in the accelerating frame the deformation is driven by the contact
// forces alone, which is exact for linear elasticity. Left out: the centrifugal and Coriolis
// forces of the body's spin (-M omega x (omega x r), -2 M omega x v), which are not rigid
// motions; free_body_validation measures their size against the contact's.
//
// Memory is sized at construction; step() allocates nothing and takes no lock.
#include <irdm/modal_model.h>
#include <irdm/rigid_body.h>
#include <irdm/vertex_contact.h>

#include <array>
#include <vector>

namespace irdm
{
  struct FreeBodyOptions
  {
    Eigen::Vector3d      gravity = Eigen::Vector3d(0, 0, -9.81); // m/s^2, world
    VertexContactOptions contact;
  };

  class FreeBodyInteraction
  {
  public:
    /// Throws InputError if the model is not of a free body (ModelFrame::free_body).
    FreeBodyInteraction(const ModalModel &model, const FreeBodyOptions &options = {});

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
    const ModalInteraction &
    deformation() const
    {
      return deformation_;
    }

    /// One step with up to contact::max_planes planes in the world frame (PlaneTarget: unit
    /// normal toward the body, a point of the plane at the step's end; stiffness as there).
    /// Returns false (no step taken) if the contact cannot be solved (too many candidates).
    bool
    step(const PlaneTarget *world_planes, int n_planes);

    /// Force of plane p on the body at the latest step (N, world).
    Eigen::Vector3d
    plane_force(int p) const
    {
      return world_force_[p];
    }
    /// Vertices of plane p in contact and its candidates, at the latest step.
    const PlaneContactResult &
    plane_result(int p) const
    {
      return deformation_.vertex_contact().plane(p);
    }
    /// World position of every output vertex (3 per vertex, m): the surface deformed by the
    /// M surface modes and placed by the rigid pose. Allocates nothing.
    void
    surface_positions(double *x) const;
    /// Rigid kinetic energy plus the deformation's energy (J); with gravity g, add
    /// -m g . c for the potential.
    double
    energy() const
    {
      return rigid_.kinetic_energy() + deformation_.elastic_energy();
    }
    double
    time_step() const
    {
      return tau_;
    }

  private:
    const ModalModel                                 &model_;
    FreeBodyOptions                                   options_;
    double                                            tau_;
    RigidBody                                         rigid_;
    RigidStepCompliance                               compliance_;
    ModalInteraction                                  deformation_;
    std::array<PlaneTarget, contact::max_planes>      body_planes_{};
    std::array<Eigen::Vector3d, contact::max_planes>  world_force_{};
    mutable std::vector<double>                       u_; // surface displacement, model frame
    std::vector<char>                                 vertex_done_; // [input vertex], scratch
  };
} // namespace irdm
