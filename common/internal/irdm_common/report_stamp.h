#pragma once
// The one line every report states about itself: when it was made and from which source.
#include <string>

namespace irdm
{
  /// "Made on 2026-11-26 14:02 UTC at commit 1a2b3c4 (irdm 0.1.0)." The commit is the source
  /// tree's, read from git when the report is written, with "+changes" when tracked files
  /// outside reports/ differ from it; "an unknown commit" where git cannot tell. reports/README.md reads it
  /// (validation/reports_index.py) to flag a report made before a later change to its code.
  std::string
  report_stamp();
} // namespace irdm
