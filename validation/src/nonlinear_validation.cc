// Where each method holds (validation/nonlinear_validation.h): the families' runs
// (nonlinear_map.cc), merged with the rows an earlier run left of the families not run, and the
// report (nonlinear_report.cc).
#include <irdm_common/error.h>
#include <irdm_common/files.h>
#include <validation/nonlinear_validation.h>

#include "nonlinear_map.h"

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <thread>

namespace fs = std::filesystem;

namespace irdm::validation
{
  namespace
  {
    using namespace nonlinear;

    bool
    runs(const NonlinearMapOptions &o, const std::string &family)
    {
      return std::find(o.families.begin(), o.families.end(), family) != o.families.end();
    }

    /// The rows an earlier run wrote in dir that this run keeps: of the families it does not
    /// make, and with --keep-rows of every case and material it does not make (`made`).
    std::vector<MapRow>
    kept_rows(const std::string &dir, const NonlinearMapOptions &o, const std::vector<MapRow> &made)
    {
      const fs::path best = fs::path(dir) / "nonlinear.csv", p1 = fs::path(dir) / "against_p1.csv";
      if (!fs::exists(best) || !fs::exists(p1))
        return {};
      std::vector<MapRow> all = read_rows(p1.string());
      for (const MapRow &r : read_rows(best.string()))
        if (r.truth != p1_truth)
          all.push_back(r);
      return rows_kept(all, made, o.families, o.keep_rows);
    }

    /// What a --keep-rows run made, for its line in commands.txt: its families, materials and
    /// cases.
    std::string
    part_made(const std::vector<MapRow> &made)
    {
      std::map<std::string, std::set<std::string>> cases; // "family, material" -> cases
      for (const MapRow &r : made)
        cases[std::string(in_planes(r.family) ? "planes" : "free") + ", " + r.material].insert(r.c);
      std::string part;
      for (const auto &[what, names] : cases)
        {
          part += (part.empty() ? "" : "; ") + what + ":";
          for (const std::string &c : names)
            part += " " + c;
        }
      return part;
    }

    /// Each family's command line (DIR/nonlinear/commands.txt, "family<TAB>command" lines):
    /// this run's for the families it ran, the earlier run's for the others; a --keep-rows
    /// run's is added under what it made, beside the earlier ones.
    std::map<std::string, std::string>
    family_commands(const std::string &dir, const NonlinearMapOptions &o, const std::vector<MapRow> &made)
    {
      std::map<std::string, std::string> commands;
      std::ifstream                      in((fs::path(dir) / "commands.txt").string());
      for (std::string line; std::getline(in, line);)
        if (const auto tab = line.find('\t'); tab != std::string::npos)
          commands[line.substr(0, tab)] = line.substr(tab + 1);
      const std::string command = o.command.empty() ? "(not recorded)" : o.command;
      const std::string later   = "rows replaced by a later run (";
      if (o.keep_rows)
        {
          if (!made.empty())
            commands[later + part_made(made) + ")"] = command;
        }
      else
        for (const std::string &f : o.families)
          {
            // A whole family's run makes every row of it again: the lines of the parts that
            // replaced some of its rows before no longer made any.
            for (auto it = commands.begin(); it != commands.end();)
              if (it->first.rfind(later, 0) == 0 && (it->first.find("(" + f + ", ") != std::string::npos ||
                                                     it->first.find("; " + f + ", ") != std::string::npos))
                it = commands.erase(it);
              else
                ++it;
            commands[f] = command;
          }
      std::ostringstream text;
      for (const auto &[family, command] : commands)
        text << family << '\t' << command << '\n';
      write_text_file((fs::path(dir) / "commands.txt").string(), text.str());
      return commands;
    }

    /// The merge's lock: another family's run may be writing; wait for it (at most 10 min).
    OutputLock
    merge_lock(const std::string &file, std::ostream &log)
    {
      for (int tries = 0;; ++tries)
        try
          {
            return OutputLock(file);
          }
        catch (const InputError &)
          {
            if (tries == 600)
              throw;
            if (tries == 0)
              log << "validate-nonlinear: waiting for another run to finish writing " << file << "\n";
            std::this_thread::sleep_for(std::chrono::seconds(1));
          }
    }
  } // namespace

  void
  run_nonlinear_validation(const NonlinearMapOptions &o, std::ostream &log)
  {
    for (const std::string &f : o.families)
      if (f != "planes" && f != "free")
        throw InputError("validate-nonlinear: no family '" + f + "' (planes, free)");
    const std::string dir = (fs::path(o.report_dir) / "nonlinear").string();
    fs::create_directories(dir);
    // Two runs of one family never share their models or rows; the planes and the free family
    // may run at once, and merge their rows in turn.
    std::vector<OutputLock> family_locks;
    for (const std::string &f : o.families)
      family_locks.emplace_back((fs::path(dir) / f).string());
    if (runs(o, "free"))
      free_family_options(o); // its options refused now, not after the plane family's hour
    std::vector<MapRow> rows;
    if (runs(o, "planes"))
      rows = run_plane_family(o, log);
    if (runs(o, "free"))
      {
        const OutputLock    models((fs::path(o.free.model_dir) / "free_cat").string());
        std::vector<MapRow> free = run_free_family(o, log);
        rows.insert(rows.end(), free.begin(), free.end());
      }
    const OutputLock          lock = merge_lock((fs::path(dir) / "nonlinear.csv").string(), log);
    const std::vector<MapRow> made = rows;
    std::vector<MapRow>       kept = kept_rows(dir, o, made);
    rows.insert(rows.begin(), kept.begin(), kept.end());
    if (rows.empty())
      throw InputError("validate-nonlinear: no rows to report (no family ran, and '" + dir +
                       "' holds none from an earlier run)");
    write_csvs(dir, rows);
    for (const char *chart : {"map.png", "map_force.png", "map_p1.png", "speed_accuracy.png"})
      fs::remove(fs::path(dir) / chart);
    if (!o.plot_script.empty())
      {
        const std::string cmd = "/usr/bin/python3 '" + o.plot_script + "' '" + dir + "'";
        if (std::system(cmd.c_str()) != 0)
          log << "validate-nonlinear: the charts were not drawn (" << cmd << " failed)\n";
      }
    write_markdown(dir, o, rows, family_commands(dir, o, made));
    log << "validate-nonlinear: wrote " << dir << "/nonlinear.csv, limits.csv, nonlinear.md\n";
  }
} // namespace irdm::validation
