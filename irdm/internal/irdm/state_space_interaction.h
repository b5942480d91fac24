#pragma once
// The runtime of a state-space model (irdm/state_space_model.h), one force-loop step:
//   history at output DoF j   C_j x[n]          (every earlier force is in the state)
//   feed-through              D = H[0]
//   contact                   the shared probe and many-vertex plane layers
//   then                      x[n + 1] = A x[n] + B f[n]   (A block-diagonal: O(r), B over
//                                                           the pushed inputs only)
// and on demand the full surface update u[n] = C x[n] + D f[n], C = output_basis c.
// step() and surface_displacement() allocate nothing and take no locks.
#include <irdm/point_interaction.h>
#include <irdm/state_space_model.h>
#include <irdm/vertex_contact.h>

#include <vector>

namespace irdm
{
  class StateSpaceInteraction : public ProbeOutputs
  {
  public:
    explicit StateSpaceInteraction(const StateSpaceModel &model,
                                   const VertexContactOptions &planes = {});

    bool
    can_touch(int triangle) const;
    bool
    can_touch(const ProbeTarget &probe) const;

    /// As PointInteraction::step: false (no force applied) if a probe cannot touch.
    bool
    step(const ProbeTarget *probes, int n_probes);
    /// Many-vertex plane contact (irdm/vertex_contact.h).
    bool
    step(const PlaneTarget *planes, int n_planes);
    const VertexContact &
    vertex_contact() const
    {
      return vertex_contact_;
    }

    /// Displacement of every output DoF after the last step (m).
    void
    surface_displacement(double *u) const;

    void
    reset();

  private:
    double
    history(unsigned input_dof) const; // at its own output
    void
    push(unsigned input_dof, double f);
    void
    advance();

    const StateSpaceModel &model_;
    std::vector<double>    x_, x_last_; // x[n] for the coming step, x of the last step taken
    std::vector<double>    f_, f_last_; // force per input DoF: this step's, the last step's
    mutable std::vector<double> y_;     // the surface update's outputs in their directions
    std::vector<unsigned>  pushed_, pushed_last_; // input DoFs with force in f_, f_last_
    unsigned               n_pushed_ = 0, n_pushed_last_ = 0;
    std::vector<char>      is_pushed_; // in pushed_
    VertexContact          vertex_contact_;
  };
} // namespace irdm
