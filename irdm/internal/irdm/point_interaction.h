#pragma once
// IRDM point interaction (seed 000, section 2; shared/notes/irdm-method.md section 3).
//
// Each probe prescribes the displacement of a surface point: a point of a model triangle given
// by barycentric weights, so a probe can move between vertices and trace along the surface.
// Every step (the force loop):
//   h_C   = sum_{s>=1} H_C[s] f[n-s]                  history term at the contact rows
//   S     = B H_CC[0] B^T                              (3P x 3P), B the spreading (barycentric,
//                                                      or a radius probe's patch weights)
//   S lambda = ubar - B h_C                            contact forces (irdm_common/contact.h)
//   f[n]  = B^T lambda                                 pushed into the force history
// and on demand the displacement of every output (the full surface update).
//
// step() and surface_displacement() allocate nothing and take no locks: every buffer is sized
// in the constructor.
#include <irdm/force_history.h>
#include <irdm/model.h>
#include <irdm/vertex_contact.h>
#include <irdm_common/contact.h>

#include <array>
#include <vector>

namespace irdm
{
  /// Where a probe touches: a point of a model triangle (barycentric weights on its 3
  /// vertices, the seeds' point interaction), or, with n_patch > 0, a patch of model vertices
  /// with weights summing to 1 (a probe with a contact radius, geometry::radius_patch, whose
  /// force converges as the mesh is refined). Either way the force spreads over the vertices
  /// by the weights and the probe's displacement is the weighted sum of theirs.
  struct ProbeTarget
  {
    int                   triangle = -1;        // model triangle touched (n_patch == 0)
    std::array<double, 3> weights  = {1, 0, 0}; // barycentric, on its vertices
    int                                      n_patch = 0; // > 0: the patch below instead
    std::array<unsigned, contact::max_patch> patch_vertices{}; // model output vertex indices
    std::array<double, contact::max_patch>   patch_weights{};
    std::array<double, 3> displacement = {0, 0, 0}; // m, prescribed for that surface point
    // m/N: a compliance in series with the probe (a virtual coupling's 1 / (k + b / tau), with
    // `displacement` its target z: contact::Coupling). 0: the rigid probe.
    double compliance = 0;
    std::array<double, 3> direction    = {0, 0, -1}; // unit push direction (unilateral)
    bool                  unilateral   = false;
    bool                  present      = true; // false: no contact this step (probe lifted)
  };

  /// What a force-loop step yields, per probe.
  struct ProbeResults
  {
    std::array<std::array<double, 3>, contact::max_probes> force{}, displacement{};
    std::array<bool, contact::max_probes>                  active{};
  };

  /// The accessors every runtime kind (direct, representatives, modal) shares, so that one
  /// harness drives them all; no virtual functions (the haptic path stays inlined).
  class ProbeOutputs
  {
  public:
    /// After step(): the force on the body at probe p (N), its contact state, and the
    /// displacement of the probed point (m).
    const std::array<double, 3> &
    force(int p) const
    {
      return results_.force[p];
    }
    bool
    active(int p) const
    {
      return results_.active[p];
    }
    const std::array<double, 3> &
    probe_displacement(int p) const
    {
      return results_.displacement[p];
    }
    /// Steps taken so far; the state after step n is FEM time (n + 1) * time_step.
    long long
    steps() const
    {
      return n_;
    }

  protected:
    ProbeResults results_;
    long long    n_ = 0;
  };

  class PointInteraction : public ProbeOutputs
  {
  public:
    /// taps: how many samples of each response to use (0: all; fewer truncates). planes: the
    /// many-vertex plane contact's margin and capacity (irdm/vertex_contact.h).
    explicit PointInteraction(const ImpulseResponseModel &model, unsigned taps = 0,
                              const VertexContactOptions &planes = {});

    /// True if a probe may touch the triangle: all its vertices are model inputs.
    bool
    can_touch(int triangle) const;
    /// True if every vertex the probe spreads over is a model input.
    bool
    can_touch(const ProbeTarget &probe) const;

    /// One force-loop step with n_probes <= contact::max_probes probes. Returns false (and
    /// applies no force) if a probe is where it cannot touch (can_touch).
    bool
    step(const ProbeTarget *probes, int n_probes);

    /// One step against n_planes <= contact::max_planes planes instead of probes (many-vertex
    /// contact, irdm/vertex_contact.h; results in vertex_contact()). Returns false (and
    /// applies no force) if more vertices are near the planes than the capacity allows.
    bool
    step(const PlaneTarget *planes, int n_planes);
    const VertexContact &
    vertex_contact() const
    {
      return vertex_contact_;
    }

    /// The full surface update: displacement of every output DoF after the last step (m).
    void
    surface_displacement(double *u) const;

    void
    reset();

  private:
    template <typename Scalar>
    void
    surface_kernel(const Scalar *H, double *u) const;
    template <typename Scalar>
    double
    history_at(const Scalar *H, unsigned output_dof) const;

    double
    history_at_contact(unsigned input_row) const;
    // History at output DoF j, the output of input DoF i (from H_CC when it is kept).
    double
    history_row(unsigned i, unsigned j) const;

    const ImpulseResponseModel &model_;
    // H_CC: the responses of the inputs at the inputs, [k][i][s] contiguous in s, so that the
    // force loop reads the contact rows' history as dot products (empty if too large: then
    // the force loop reads the strided model directly).
    std::vector<double>         h_cc_;
    unsigned                    taps_;
    ForceHistory                history_; // taps slots per input, kept for taps steps
    VertexContact               vertex_contact_;
  };
} // namespace irdm
