#pragma once
// Numbers in report text (Markdown, logs): printf-style, 3 significant digits by default.
#include <cstdio>
#include <sstream>
#include <string>

namespace irdm
{
  inline std::string
  fmt(const double x, const char *format = "%.3g")
  {
    char b[64];
    std::snprintf(b, sizeof b, format, x);
    return b;
  }

  /// x as a stream prints it by default (6 significant digits): steps, durations and material
  /// constants as a report states them.
  inline std::string
  plain(const double x)
  {
    std::ostringstream s;
    s << x;
    return s.str();
  }
} // namespace irdm
