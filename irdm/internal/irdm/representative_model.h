#pragma once
// Compression of impulse responses by representative waveforms (seed 000, section 3;
// shared/notes/irdm-method.md section 4; the algorithm is documented in docs/compression.md).
//
// Every waveform w = H_kj (input DoF k, output DoF j, T samples) is stored either as a
// representative, or as a blend of `blend` representatives of the same input, each delayed by
// d >= 0 steps and scaled by an amplitude a:
//     w[s] ~ sum_b a_b r_b[s - d_b]          (r[s] = 0 outside 0 <= s < T)
// Delays are causal (d >= 0) so that the runtime can read a delayed copy of a representative's
// convolution instead of convolving again: each representative is convolved once per step
// with its input's force history, and a substituted waveform costs one read per blend term.
#include <irdm_common/files.h>
#include <irdm/model.h>

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

namespace irdm
{
  struct CompressionOptions
  {
    double   theta      = 0.9; // correlation threshold in (0, 1]
    unsigned max_delay  = 64;  // steps; delays searched 0 .. max_delay
    unsigned blend      = 1;   // representatives per substituted waveform (1: the seed's plain
                               // substitution; 2..4: interpolation among nearby ones)
    unsigned candidates = 8;   // nearest representatives (by output vertex) searched
    unsigned threads    = 0;   // 0: all hardware threads
    std::function<void(const std::string &)> log; // progress lines
  };

  struct RepresentativeModel : ModelFrame
  {
    // How it was made.
    double   theta = 0, compression_seconds = 0;
    unsigned max_delay = 0, blend = 1, candidates = 0;
    unsigned delay_span = 0; // the largest delay actually used (runtime ring length - 1)
    std::string source_file;

    // Representatives of input k: rows first_representative[k] .. first_representative[k+1]-1
    // of `representatives` ([row][s], T samples each, float, m/N).
    std::vector<std::uint64_t> first_representative; // n_inputs + 1
    std::vector<float>         representatives;
    // Blend terms of waveform (k, j), slot b: at [(k * n_outputs + j) * blend + b]. The
    // representative index is local to input k; unused slots have amplitude 0.
    std::vector<std::uint32_t> term_representative;
    std::vector<std::uint16_t> term_delay;
    std::vector<float>         term_amplitude;

    // Statistics (counted over waveforms).
    std::uint64_t n_substituted = 0;
    double        mean_fit = 0, min_fit = 0; // fit correlation of substituted waveforms
    double        mean_delay = 0;            // mean delay of substituted waveforms (steps)

    /// Representative waveforms stored (all inputs).
    std::uint64_t
    n_representative() const
    {
      return first_representative.empty() ? 0 : first_representative.back();
    }
    /// Bytes of the compressed data in memory: representatives and blend-term tables.
    double
    bytes() const;
    /// Bytes of the representatives alone (what the seed's Table 1 counts).
    double
    representative_bytes() const
    {
      return 4.0 * representatives.size();
    }
    /// The response the compressed model stands for: sum_b a_b r_b[s - d_b], for
    /// s < length + delay_span (a delayed representative runs past T).
    double
    response(unsigned input_dof, unsigned s, unsigned output_dof) const;
  };

  /// Compresses a loaded model. Waveforms of one input are visited in order of distance of
  /// their output vertex from the input vertex (the elastic wave reaches them in that order,
  /// so representatives come first and the later waveforms are their delayed copies).
  RepresentativeModel
  compress(const ImpulseResponseModel &model, const CompressionOptions &options);

  /// HDF5 file `irdm-representative-model` version 1 (docs/model-format.md): the source model's
  /// metadata and groups, plus /representatives. Written atomically.
  void
  save_representative_model(const RepresentativeModel &m, const std::string &source_file,
                            const std::string &path, OutputLock lock = {});
  RepresentativeModel
  load_representative_model(const std::string &path,
                            std::optional<double> expected_time_step = {});
} // namespace irdm
