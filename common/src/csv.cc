#include <irdm_common/csv.h>
#include <irdm_common/error.h>

#include <cstdio>
#include <fstream>

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
    const std::string tmp = path + ".part";
    {
      std::ofstream out(tmp);
      if (!out)
        throw InputError("cannot write '" + path + "'");
      for (std::size_t j = 0; j < header.size(); ++j)
        out << (j ? "," : "") << header[j];
      out << '\n';
      char buf[32];
      for (std::size_t i = 0; i < rows; ++i)
        {
          for (std::size_t j = 0; j < columns.size(); ++j)
            {
              std::snprintf(buf, sizeof buf, "%.17g", columns[j][i]);
              out << (j ? "," : "") << buf;
            }
          out << '\n';
        }
      if (!out)
        throw InputError("error while writing '" + path + "'");
    }
    if (std::rename(tmp.c_str(), path.c_str()) != 0)
      throw InputError("cannot move '" + tmp + "' to '" + path + "'");
  }
} // namespace irdm
