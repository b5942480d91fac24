#pragma once
// Internal: reading the part every model file shares (docs/model-format.md: root attributes,
// /outputs, /inputs, /surface), so the loaders of the uncompressed and the compressed models
// check it the same way.
#include <irdm/model.h>
#include <irdm_common/h5.h>

#include <optional>
#include <string>

namespace irdm
{
  /// Throws InputError naming the file for a missing dataset, bad shapes, indices out of
  /// range, a non-positive step or length, or a step different from expected_time_step.
  void
  read_frame(const h5::Reader &r, const std::string &path, ModelFrame &m,
             std::optional<double> expected_time_step);

  /// InputError if the file carries /progress/chunk_done (a precompute's progress) with a chunk
  /// not written: an interrupted or clashing run, never a model.
  void
  check_complete(const h5::Reader &r, const std::string &path);
} // namespace irdm
