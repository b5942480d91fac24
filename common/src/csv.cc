#include <irdm_common/csv.h>
#include <irdm_common/error.h>
#include <irdm_common/files.h>

#include <cerrno>
#include <cstdio>
#include <cstring>

namespace irdm
{
  void
  write_csv(const std::string &path,
            const std::vector<std::string> &header,
            const std::vector<std::vector<double>> &columns)
  {
    if (header.size() != columns.size())
      throw std::logic_error("write_csv: header and column counts differ");
    const std::size_t rows = columns.empty() ? 0 : columns[0].size();
    for (const auto &c : columns)
      if (c.size() != rows)
        throw std::logic_error("write_csv: columns of different length");
    const std::string part = path + ".part";
    std::FILE        *out  = std::fopen(part.c_str(), "wb");
    if (!out)
      throw IoError("cannot create '" + part + "': " + std::strerror(errno));
    bool ok = true;
    for (std::size_t j = 0; j < header.size() && ok; ++j)
      ok = std::fprintf(out, "%s%s", j ? "," : "", header[j].c_str()) >= 0;
    ok = ok && std::fputc('\n', out) != EOF;
    for (std::size_t i = 0; i < rows && ok; ++i)
      {
        for (std::size_t j = 0; j < columns.size() && ok; ++j)
          ok = std::fprintf(out, "%s%.17g", j ? "," : "", columns[j][i]) >= 0;
        ok = ok && std::fputc('\n', out) != EOF;
      }
    ok           = std::fflush(out) == 0 && ok;
    const int e  = errno;
    const bool closed = std::fclose(out) == 0;
    if (!ok || !closed)
      {
        std::remove(part.c_str());
        throw IoError("cannot write '" + path + "': " + std::strerror(ok ? errno : e));
      }
    commit_part_file(part, path);
  }
} // namespace irdm
