#pragma once
// Column-oriented CSV output: one header line, then one row per sample, full precision.
#include <string>
#include <vector>

namespace irdm
{
  /// Writes columns of equal length. Throws InputError if the file cannot be written.
  void
  write_csv(const std::string &path,
            const std::vector<std::string> &header,
            const std::vector<std::vector<double>> &columns);
} // namespace irdm
