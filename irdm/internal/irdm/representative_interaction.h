#pragma once
// IRDM point interaction run directly from a representative-waveform model (no decompression).
//
// Per step n, for every input k with force inside the window and every representative r of k:
//   p_r = sum_{s>=1} r[s] f_k[n - s]          (before this step's force is known)
//   c_r[n] = p_r + r[0] f_k[n]                (after the contact solve)
// A waveform a r[s - d] then contributes a c_r[n - d] (d >= 1) or a p_r (d = 0, history part)
// to its output: one read per blend term. c_r is kept for delay_span + 1 steps in a ring.
// The feed-through H[0] of the contact solve is sum over d = 0 terms of a r[0].
//
// Same interface and the same guarantees as PointInteraction: step() and
// surface_displacement() allocate nothing and take no locks.
#include <irdm/point_interaction.h>
#include <irdm/representative_model.h>

#include <vector>

namespace irdm
{
  class RepresentativeInteraction : public ProbeOutputs
  {
  public:
    explicit RepresentativeInteraction(const RepresentativeModel &model);

    bool
    can_touch(int triangle) const;
    bool
    can_touch(const ProbeTarget &probe) const;
    bool
    step(const ProbeTarget *probes, int n_probes);
    void
    surface_displacement(double *u) const;

  private:
    double
    history_at(unsigned output_dof) const;
    double
    feed_through(unsigned input_dof, unsigned output_dof) const;

    const RepresentativeModel &model_;
    unsigned                   T_, ring_; // ring_ = delay_span + 1
    // Per term, the offset of its delayed read in c_ (representative row * 2 ring + ring - d);
    // add the current ring slot to read c_r[n - d].
    std::vector<std::uint32_t> term_offset_;
    ForceHistory               history_;  // T slots per input, kept for T + ring steps
    std::vector<double>        partial_;  // p_r, per representative
    std::vector<double>        c_;        // [r][2 ring]: each value written twice (no modulo)
  };
} // namespace irdm
