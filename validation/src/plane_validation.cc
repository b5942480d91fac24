// Virtual-DOF and many-vertex plane contact against the nonlinear FEM
// (validation/plane_validation.h): the cases (plane_cases.cc), each through the truth and every
// method (plane_runs.cc, plane_coupling.cc), and the report (plane_report.cc).
#include <irdm_common/error.h>
#include <reference_fem/scene.h>
#include <validation/plane_validation.h>

#include "plane_runs.h"

#include <algorithm>
#include <cstdlib>
#include <filesystem>

namespace fs = std::filesystem;

namespace irdm::validation
{
  namespace
  {
    /// The run's cases, those that options.cases names (by name or kind) where it names any;
    /// a name that matches no case is refused.
    std::vector<planes::Case>
    selected_cases(std::vector<planes::Case> all, const PlaneValidationOptions &o)
    {
      const auto named = [&](const planes::Case &c, const std::string &n) {
        return c.name == n || c.kind == n;
      };
      for (const std::string &n : o.cases)
        if (std::none_of(all.begin(), all.end(), [&](const planes::Case &c) { return named(c, n); }))
          throw InputError("validate-planes: --cases names '" + n + "', which is neither a case "
                           "nor a kind of case of this run" + (o.quick ? " (--quick)" : ""));
      if (o.cases.empty())
        return all;
      std::vector<planes::Case> kept;
      for (auto &c : all)
        if (std::any_of(o.cases.begin(), o.cases.end(), [&](const std::string &n) { return named(c, n); }))
          kept.push_back(std::move(c));
      return kept;
    }
  } // namespace

  void
  run_plane_validation(const PlaneValidationOptions &o, std::ostream &log)
  {
    using namespace planes;
    const fem::Scene body = grounded_body(o.scene);
    const std::string dir = (fs::path(o.report_dir) / "planes").string();
    fs::create_directories(dir);

    // The case names do not depend on the model's directions: checked before any model is made.
    const std::vector<Case> names = selected_cases(plane_cases(Directions{}, o.quick), o);
    for (const std::string &name : o.converged_degree > 0 ? o.converged_cases : std::vector<std::string>{})
      if (std::none_of(names.begin(), names.end(), [&](const Case &c) { return c.name == name; }))
        throw InputError("validate-planes: --converged-cases names '" + name +
                         "', which is not a case of this run" + (o.quick ? " (--quick)" : "") +
                         (o.cases.empty() ? "" : " (--cases): give --converged-cases among "
                                                 "the chosen cases, or --converged-degree 0"));
    const PlaneModels models = prepare_models(body, o, log);
    PlaneStudy        study{o, body, models, case_directions(models.vdof), {}, {}, {}, {}};
    std::vector<unsigned> fem_order;
    for (const Case &c : selected_cases(plane_cases(study.directions, o.quick), o))
      {
        CaseResult r = run_case(c, body, models, o, fem_order, log);
        study.rows.push_back(std::move(r.row));
        for (auto &w : r.sweep)
          study.sweep.push_back(std::move(w));
      }
    study.plate   = run_plate_study(body, models, study.directions.side, log);
    study.mapping = mapping_rows(study.rows, models.vdof);
    write_plane_report(dir, study);
    if (!o.plot_script.empty())
      {
        const std::string cmd = "/usr/bin/python3 '" + o.plot_script + "' '" + dir + "'";
        if (std::system(cmd.c_str()) != 0)
          log << "warning: the chart script failed: " << cmd << "\n";
      }
    log << "report: " << dir << "/planes.md\n";
  }
} // namespace irdm::validation
