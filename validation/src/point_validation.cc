// IRDM point interaction against the reference FEM (validation/point_validation.h). Data flow:
// scene -> FEM run (ground truth) and precompute -> model file -> IRDM runtime -> comparison ->
// report. The runner is point_runs.cc and point_full_model.cc; the writer point_report.cc.
#include <irdm_common/error.h>
#include <reference_fem/scene.h>
#include <validation/point_validation.h>

#include "point_runs.h"

#include <algorithm>
#include <cstdlib>

namespace fs = std::filesystem;

namespace irdm::validation
{
  namespace
  {
    /// The scene files of the folder (sorted), and those to run (--only filters by scene
    /// name), each checked to have something to validate.
    std::pair<std::vector<std::string>, std::vector<std::string>>
    scene_files(const PointValidationOptions &o)
    {
      if (!fs::is_directory(o.scenes_dir))
        throw InputError("scene folder '" + o.scenes_dir + "' does not exist");
      std::vector<std::string> all, files;
      for (const auto &e : fs::directory_iterator(o.scenes_dir))
        if (e.path().extension() == ".json")
          all.push_back(e.path().string());
      std::sort(all.begin(), all.end());
      for (const auto &file : all)
        {
          const fem::Scene scene = fem::read_scene(file);
          if (!o.only.empty() && std::find(o.only.begin(), o.only.end(), scene.name) == o.only.end())
            continue;
          if (scene.probes.empty())
            throw InputError("scene '" + file + "' has no probes: nothing to validate");
          if (!(scene.duration > 0))
            throw InputError("scene '" + file + "' gives no time.duration_s");
          files.push_back(file);
        }
      if (files.empty())
        throw InputError("no scene to run in '" + o.scenes_dir + "'");
      return {all, files};
    }
  } // namespace

  bool
  run_point_validation(const PointValidationOptions &o, std::ostream &log)
  {
    using namespace points;
    const auto [all, files] = scene_files(o);
    fs::create_directories(o.model_dir);
    fs::create_directories(o.report_dir);
    bool        all_exact = true;
    std::string scenes_table;
    std::vector<std::pair<std::string, std::vector<CompressionRow>>> compression;
    for (const auto &file : files)
      {
        const SceneRun r   = run_scene(file, o, log);
        const fs::path dir = fs::path(o.report_dir) / r.scene.name;
        write_scene_report(dir, r);
        all_exact = all_exact && r.pass;
        scenes_table += summary_row(r);
        compression.push_back({r.scene.name, r.compression});
        if (!o.plot_script.empty())
          {
            const std::string cmd = "/usr/bin/python3 '" + o.plot_script + "' '" + dir.string() + "'";
            if (std::system(cmd.c_str()) != 0)
              log << "  note: charts not drawn (python3-matplotlib missing?)\n";
          }
      }
    // The full model is driven by the folder's first scene.
    std::optional<FullModelRun> full;
    if (o.full_model)
      full = run_full_model(all.front(), o, log);
    write_validation_summary(o, scenes_table, compression, full);
    if (full && !o.plot_script.empty())
      {
        // The full model's speed and memory charts, drawn as each scene's are.
        const fs::path    report = o.report_dir;
        const std::string script =
          (fs::path(o.plot_script).parent_path() / "plot_compression.py").string();
        const std::string cmd = "/usr/bin/python3 '" + script + "' '" +
                                (report / "full_model_compression.csv").string() + "' '" +
                                (report / "full_model_speed_accuracy.png").string() + "' '" +
                                (report / "full_model_memory_accuracy.png").string() + "'";
        if (std::system(cmd.c_str()) != 0)
          log << "  note: the full model's charts not drawn (python3-matplotlib missing?)\n";
      }
    log << "report: " << (fs::path(o.report_dir) / "validation.md").string() << "\n";
    return all_exact;
  }
} // namespace irdm::validation
