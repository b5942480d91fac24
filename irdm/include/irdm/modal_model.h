#pragma once
// A second compressor: the modal (state-space) realization of H. The precompute's H is exactly
//   H_kj[s] = sum_i phi_i(j) phi_i(k) q_i[s],
// q_i the response of mode i to the FEM's own integrator step (irdm/model.h, ModalData). Keep
// the lowest M modes as a recursion (3 numbers of state per mode, one step matrix each) and
// replace the rest by L residual taps taken from H itself:
//   E[s] = H[s] - H_M[s] for s < L - 1,   E[L - 1] = sum_{s >= L - 1} (H[s] - H_M[s]),
// so the model keeps H's static compliance sum_s H[s] exactly (and H[0] too when L >= 2) and
// approximates only the dynamics of the dropped modes (docs/compression.md).
// Cost per step: O(M) for the state, O(n_out M) for the full surface update, independent of T.
#include <irdm/model.h>
#include <irdm/point_interaction.h>

#include <vector>

namespace irdm
{
  struct ModalModelOptions
  {
    unsigned modes         = 100; // M lowest modes kept
    unsigned residual_taps = 2;   // L >= 1
  };

  struct ModalModel : ModelFrame
  {
    unsigned            n_modes = 0, residual_taps = 0;
    double              highest_frequency_hz = 0, build_seconds = 0;
    std::vector<double> shapes;       // [output DoF][mode]
    std::vector<double> input_shapes; // [input DoF][mode]
    std::vector<double> step;         // [mode][3 x 5], as ModalData::step
    std::vector<float>  residual;     // [input DoF][tap][output DoF]
    /// Bytes in memory.
    double
    bytes() const
    {
      return 8.0 * (shapes.size() + input_shapes.size() + step.size()) + 4.0 * residual.size();
    }
  };

  /// Throws InputError if the model file carried no modal realization or asks for more modes
  /// than it has.
  ModalModel
  make_modal_model(const ImpulseResponseModel &model, const ModalModelOptions &options);

  /// Point interaction run from a modal model; same interface and guarantees as
  /// PointInteraction (step() and surface_displacement() allocate nothing).
  class ModalInteraction
  {
  public:
    explicit ModalInteraction(const ModalModel &model);
    bool
    can_touch(int triangle) const;
    bool
    step(const ProbeTarget *probes, int n_probes);
    const std::array<double, 3> &
    force(int p) const
    {
      return force_[p];
    }
    bool
    active(int p) const
    {
      return active_[p];
    }
    const std::array<double, 3> &
    probe_displacement(int p) const
    {
      return probe_u_[p];
    }
    void
    surface_displacement(double *u) const;
    long long
    steps() const
    {
      return n_;
    }

  private:
    double
    residual_history(unsigned output_dof) const;

    const ModalModel      &model_;
    unsigned               M_, L_;
    long long              n_ = 0;
    std::vector<double>    x_;       // [mode][3] state after the last step
    std::vector<double>    u_modal_; // [mode] modal displacement (x's first component)
    std::vector<double>    free_;    // [mode][3] this step's state without this step's force
    std::vector<double>    g_prev_;  // [mode] modal force of the last step
    std::vector<double>    history_; // [input DoF][slot], slot = step % L (residual taps)
    std::vector<long long> last_nonzero_;
    std::vector<unsigned>  active_inputs_;
    std::vector<char>      is_active_input_;
    std::array<std::array<double, 3>, contact::max_probes> force_{}, probe_u_{};
    std::array<bool, contact::max_probes>                  active_{};
  };
} // namespace irdm
