#pragma once
// Numbers in report text (Markdown, logs): printf-style, 3 significant digits by default.
#include <cstdio>
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
} // namespace irdm
