#include <irdm_common/report_stamp.h>

#include <array>
#include <cstdio>
#include <ctime>

namespace irdm
{
  namespace
  {
    // The first line a shell command prints ("" if it fails or prints nothing).
    std::string
    first_line(const std::string &command)
    {
      std::string out;
      if (FILE *p = ::popen(command.c_str(), "r"))
        {
          std::array<char, 256> buffer{};
          if (std::fgets(buffer.data(), buffer.size(), p))
            out = buffer.data();
          if (::pclose(p) != 0)
            out.clear();
        }
      while (!out.empty() && (out.back() == '\n' || out.back() == '\r'))
        out.pop_back();
      return out;
    }
  } // namespace

  std::string
  report_stamp()
  {
    const std::string git    = "git -C '" IRDM_SOURCE_DIR "' ";
    std::string       commit = first_line(git + "rev-parse --short=7 HEAD 2>/dev/null");
    if (commit.empty())
      commit = "an unknown commit";
    else
      {
        commit = "commit " + commit;
        // Changes to the committed reports themselves (which a run rewrites) do not count.
        if (!first_line(git + "status --porcelain --untracked-files=no -- . ':(exclude)reports' "
                              "2>/dev/null")
               .empty())
          commit += "+changes";
      }
    char             date[32] = "an unknown date";
    const std::time_t now     = std::time(nullptr);
    std::tm          utc{};
    if (gmtime_r(&now, &utc))
      std::strftime(date, sizeof date, "%Y-%m-%d %H:%M UTC", &utc);
    return "Made on " + std::string(date) + " at " + commit + " (irdm " IRDM_VERSION ").";
  }
} // namespace irdm
