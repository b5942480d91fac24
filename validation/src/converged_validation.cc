// The validation scenes on a converged discretization (converged_validation.h): scene ->
// (coarse, converged) discretization -> FEM run and model precompute -> IRDM run ->
// method error and discretization error -> reports/converged/.
#include <irdm/modal_model.h>
#include <irdm/model.h>
#include <irdm_common/error.h>
#include <irdm_common/report_stamp.h>
#include <irdm_common/files.h>
#include <irdm_common/format.h>
#include <reference_fem/elastodynamics.h>
#include <reference_fem/impulse_response.h>
#include <reference_fem/mesh.h>
#include <reference_fem/scene.h>
#include <validation/converged_validation.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <functional>
#include <map>
#include <optional>
#include <sstream>

#include <irdm_common/report_template.h>
#include "scene_runs.h"

namespace fs = std::filesystem;

namespace irdm::validation
{
  namespace
  {
    // The longest edge of the mesh's tagged boundary triangles (m): a model region that
    // reaches this far beyond a probe's patch holds every triangle touching the patch, so
    // the runtime's patch weights (lumped areas) are the FEM's.
    double
    longest_boundary_edge(const std::string &mesh_file)
    {
      const fem::TetMesh mesh = fem::read_gmsh(mesh_file);
      double             longest = 0;
      for (const auto &t : mesh.triangles)
        for (int k = 0; k < 3; ++k)
          {
            const auto &a = mesh.vertices[t[k]], &b = mesh.vertices[t[(k + 1) % 3]];
            longest = std::max(longest, norm({a[0] - b[0], a[1] - b[1], a[2] - b[2]}));
          }
      return longest;
    }

    // Balls that hold every point within `radius` of a path (straight between its points):
    // centres every radius / 4 along it, each of radius `radius` + half that spacing +
    // `margin`. A path of one point gives one ball of radius + margin.
    std::vector<std::pair<Vec3, double>>
    balls_along(const std::vector<Vec3> &path, const double radius, const double margin)
    {
      std::vector<std::pair<Vec3, double>> balls;
      if (path.size() == 1)
        balls.push_back({path[0], radius + margin});
      for (size_t i = 0; i + 1 < path.size(); ++i)
        {
          const Vec3   &a = path[i], &b = path[i + 1];
          const double  length = norm({b[0] - a[0], b[1] - a[1], b[2] - a[2]});
          const int     n      = std::max(1, static_cast<int>(std::ceil(length / (radius / 4))));
          for (int k = 0; k <= n; ++k)
            {
              const double t = static_cast<double>(k) / n;
              balls.push_back({{a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1]),
                                a[2] + t * (b[2] - a[2])},
                               radius + length / n / 2 + margin});
            }
        }
      return balls;
    }

    struct Discretization
    {
      std::string label; // "coarse" (the scene's own) or "converged"
      std::string mesh_file;
      unsigned    degree = 1;
    };

    // One scene on one discretization: its runs and what they cost.
    struct Outcome
    {
      Discretization d;
      unsigned       free_dofs = 0, patch_vertices = 0, model_inputs = 0, modes = 0, lowest = 0;
      bool           sparse = false;
      double         stiffness = 0; // N/m, first probe's driving point
      double         precompute_seconds = 0, stiffness_seconds = 0;
      double         fem_step_seconds = 0, irdm_force_loop_seconds = 0;
      Series         fem, irdm;
    };

    // Force-only copy: compare() then measures the probe forces alone (different meshes have
    // different surface vertices).
    Series
    forces_of(const Series &s)
    {
      Series f;
      f.force = s.force;
      return f;
    }

    struct ForceErrors
    {
      double rel_l2 = 0, peak = 0, impulse = 0;
    };

    // Relative L2 over the run, relative error of the peak force magnitude, and relative error
    // of the impulse (the sum of force x step over the run, as a vector), all probes together.
    ForceErrors
    force_errors(const Series &test, const Series &truth)
    {
      ForceErrors e;
      e.rel_l2 = compare(forces_of(test), forces_of(truth)).force_rel_l2;
      const double pt = peak_force(test), pr = peak_force(truth);
      e.peak          = std::abs(pt - pr) / pr;
      double dj = 0, j = 0;
      for (size_t p = 0; p < truth.force.size(); ++p)
        {
          Vec3 a{0, 0, 0}, b{0, 0, 0};
          const size_t N = std::min(test.force[p].size(), truth.force[p].size());
          for (size_t k = 0; k < N; ++k)
            for (int c = 0; c < 3; ++c)
              a[c] += test.force[p][k][c], b[c] += truth.force[p][k][c];
          dj += std::pow(norm({a[0] - b[0], a[1] - b[1], a[2] - b[2]}), 2);
          j += std::pow(norm(b), 2);
        }
      e.impulse = std::sqrt(dj / j);
      return e;
    }

    // A model made once and shared by every scene on the same body, discretization and model
    // region (press, tap and tap_coupled touch the same place): its file and what made it.
    struct CachedModel
    {
      std::string path;
      unsigned    modes = 0, lowest = 0;
      bool        sparse = false;
      double      seconds = 0;
    };

    std::string
    pct(const double x)
    {
      return fmt(100 * x, "%.3g") + " %";
    }

    /// The model of a scene's body, discretization and region, made once (scenes on the same
    /// region share it) into --models.
    const CachedModel &
    model_for(const fem::Scene &scene, const std::string &name, const Discretization &d,
              const ConvergedValidationOptions &o, const unsigned length,
              std::map<std::string, CachedModel> &models, std::ostream &log)
    {
      std::string key = d.label;
      for (const auto &b : scene.model.inputs->balls)
        key += "," + fmt(b.first[0], "%.9g") + "," + fmt(b.first[1], "%.9g") + "," +
               fmt(b.first[2], "%.9g") + "," + fmt(b.second, "%.9g");
      if (models.count(key) == 0)
        {
          fem::PrecomputeOptions po;
          po.output = (fs::path(o.model_dir) /
                       (name + "_" + d.label + ".h5")).string();
          if (fs::exists(po.output))
            throw InputError("'" + po.output + "' exists; validate-converged writes its working "
                             "models to --models and removes them after use, so it never "
                             "touches a file already there: move it or choose another --models "
                             "folder");
          po.length  = length;
          po.restart = true;
          // The coarse model has every mode and double storage (exact: its method error is
          // round-off); the converged one the lowest modes plus residual modes, in float (its
          // H is GBs), whose round-off (1e-7) is far below its modal truncation.
          const bool coarse = d.label == "coarse";
          po.double_storage = coarse;
          if (!coarse)
            {
              po.modes = o.modes;
              // The modal runtime alone runs it: H (inputs x T x outputs, 26.9 GB for trace's
              // region) is not written.
              po.modal_only = true;
            }
          po.log = [&log](const std::string &line) { log << "    " << line << std::endl; };
          const auto pre = fem::precompute_impulse_responses(scene, po);
          models[key]    = {po.output, pre.n_modes, pre.n_lowest, pre.sparse, pre.seconds_total};
        }
      else
        log << "    the model of scene '" << fs::path(models[key].path).stem().string()
            << "' (same body and region)" << std::endl;
      return models[key];
    }

    Outcome
    run_one(const fem::Scene &base, const Discretization &d, const ConvergedValidationOptions &o,
            const unsigned length, std::map<std::string, CachedModel> &models, std::ostream &log)
    {
      Outcome r;
      r.d = d;
      fem::Scene scene = base;
      scene.mesh_file  = d.mesh_file;
      scene.fe_degree  = d.degree;
      // The model's region: the scene's balls widened, and balls along every probe's path, so
      // that each patch the probe touches and the triangles around it are inside; inputs =
      // outputs.
      if (!scene.model.inputs || scene.model.inputs->balls.empty())
        throw InputError("scene '" + base.name + "': validate-converged needs model.inputs.within "
                         "(balls around the probes): a model of every surface vertex of a "
                         "converged mesh does not fit in memory");
      const double margin = longest_boundary_edge(d.mesh_file);
      for (auto &b : scene.model.inputs->balls)
        b.second = std::max(b.second, o.probe_radius) + margin;
      for (const auto &p : scene.probes)
        for (const auto &b : balls_along(p.path.values, p.radius, margin))
          scene.model.inputs->balls.push_back(b);
      scene.model.outputs = scene.model.inputs;

      const unsigned N = scene.n_steps();
      {
        fem::ElasticDynamics fem(scene);
        const auto           c = fem.probe_compliance(0);
        r.free_dofs          = fem.n_free_dofs();
        r.stiffness          = c.stiffness.at(0);
        r.patch_vertices     = c.n_vertices.at(0);
        r.stiffness_seconds  = c.seconds;
      }
      log << "  " << d.label << " (" << fs::path(d.mesh_file).filename().string() << " P"
          << d.degree << ", " << r.free_dofs << " free DoFs): probe stiffness "
          << fmt(r.stiffness, "%.4g") << " N/m over " << r.patch_vertices << " vertices" << std::endl;

      const CachedModel &cm = model_for(scene, base.name, d, o, length, models, log);
      r.precompute_seconds  = cm.seconds;
      r.modes               = cm.modes;
      r.lowest              = cm.lowest;
      r.sparse              = cm.sparse;
      {
        const ImpulseResponseModel model =
          load_model(cm.path, scene.time_step, ModelParts::modal_realization);
        r.model_inputs                   = model.n_inputs;
        log << "    FEM run (" << N << " steps)" << std::endl;
        r.fem = run_fem(scene, model, 1, N);
        log << "    IRDM run" << std::endl;
        // The modal realization with every mode in the force loop and in the surface update:
        // H itself (to the precompute's stated bound), at O(modes) per step instead of the
        // direct convolution's O(inputs x outputs x T).
        const ModalModel mm = make_modal_model(model, {model.modes.n_modes, 0});
        ModalInteraction irdm(mm);
        r.irdm = run_irdm(scene, mm, irdm, true);
      }
      r.fem_step_seconds        = r.fem.step_seconds;
      r.irdm_force_loop_seconds = r.irdm.force_loop_seconds;
      log << "    model " << r.model_inputs << " inputs = outputs, " << r.modes << " modes ("
          << r.lowest << " lowest) in " << fmt(r.precompute_seconds) << " s; FEM "
          << fmt(1e3 * r.fem.step_seconds) << " ms/step; method error (force rel. L2) "
          << fmt(compare(r.irdm, r.fem).force_rel_l2) << std::endl;
      return r;
    }

    /// The named scenes, read and checked before any work; `length`: the longest scene's steps
    /// (the models' T, so that a model serves every scene on its region untruncated).
    std::vector<fem::Scene>
    read_scenes(const ConvergedValidationOptions &o, unsigned &length)
    {
      std::vector<fem::Scene> scenes;
      length = 1;
      for (const auto &name : o.scenes)
        {
          const std::string file = (fs::path(o.scenes_dir) / (name + ".json")).string();
          if (!fs::exists(file))
            throw InputError("validate-converged: no scene '" + file + "'");
          scenes.push_back(fem::read_scene(file));
          if (scenes.back().probes.empty())
            throw InputError("scene '" + name + "' has no probes: nothing to validate");
          for (auto &p : scenes.back().probes)
            if (p.radius == 0)
              p.radius = o.probe_radius;
          length = std::max(length, scenes.back().n_steps());
        }
      return scenes;
    }

    /// Whether a scene's first probe is the one the extrapolated stiffness belongs to (the
    /// first of --extrapolated-scene): the same start point and direction.
    std::function<bool(const fem::Scene &)>
    extrapolated_probe_test(const ConvergedValidationOptions &o)
    {
      if (!(o.extrapolated_stiffness > 0))
        return [](const fem::Scene &) { return false; };
      const fem::Scene e =
        fem::read_scene((fs::path(o.scenes_dir) / (o.extrapolated_scene + ".json")).string());
      if (e.probes.empty())
        throw InputError("validate-converged: scene '" + o.extrapolated_scene +
                         "' (--extrapolated-scene) has no probe");
      const Vec3 ex = e.probes[0].path.at(0), ed = e.probes[0].direction;
      return [ex, ed](const fem::Scene &sc) {
        if (sc.probes.empty())
          return false;
        const Vec3 x = sc.probes[0].path.at(0), d = sc.probes[0].direction;
        return norm({x[0] - ex[0], x[1] - ex[1], x[2] - ex[2]}) < 1e-9 &&
               norm({d[0] - ed[0], d[1] - ed[1], d[2] - ed[2]}) < 1e-9;
      };
    }

    /// One scene on one discretization, scored: the method error (IRDM against the same FEM)
    /// and, against the converged FEM, the discretization error of its FEM and of its model.
    struct Row
    {
      std::string scene;
      Outcome     run; // its series emptied once scored
      ForceErrors method, fem_vs_truth, model_vs_truth;
      double      method_disp_rms = 0;
      double      vs_extrapolated = NAN; // stiffness / extrapolated - 1
      bool        is_truth = false;
    };

    /// series.csv's rows of one scene: each probe's force along its direction.
    std::string
    series_rows(const fem::Scene &base, const std::vector<Outcome> &runs)
    {
      std::ostringstream series;
      const Series      &truth = runs.back().fem;
      for (size_t p = 0; p < base.probes.size(); ++p)
        {
          const Vec3 &dir_p = base.probes[p].direction;
          const auto  along = [&](const Series &s, size_t k) {
            const Vec3 &f = s.force[p][k];
            return f[0] * dir_p[0] + f[1] * dir_p[1] + f[2] * dir_p[2];
          };
          for (size_t k = 0; k < truth.force[p].size(); ++k)
            series << base.name << "," << fmt((k + 1) * base.time_step, "%.6g") << ","
                   << base.probes[p].name << "," << fmt(along(runs[0].fem, k), "%.8g") << ","
                   << fmt(along(runs[0].irdm, k), "%.8g") << "," << fmt(along(runs[1].fem, k), "%.8g")
                   << "," << fmt(along(runs[1].irdm, k), "%.8g") << "\n";
        }
      return series.str();
    }

    /// converged.csv's row.
    std::string
    csv_row(const Row &r)
    {
      const Outcome &o = r.run;
      std::ostringstream csv;
      csv << r.scene << "," << o.d.label << "," << fs::path(o.d.mesh_file).stem().string() << ","
          << o.d.degree << "," << o.free_dofs << "," << o.patch_vertices << ","
          << fmt(o.stiffness, "%.6g") << "," << fmt(r.vs_extrapolated, "%.4g") << ","
          << o.model_inputs << "," << o.modes << "," << o.lowest << ","
          << fmt(r.method.rel_l2, "%.4g") << "," << fmt(r.method.peak, "%.4g") << ","
          << fmt(r.method.impulse, "%.4g") << "," << fmt(r.method_disp_rms, "%.4g") << ","
          << fmt(r.fem_vs_truth.rel_l2, "%.4g") << "," << fmt(r.fem_vs_truth.peak, "%.4g") << ","
          << fmt(r.fem_vs_truth.impulse, "%.4g") << "," << fmt(r.model_vs_truth.rel_l2, "%.4g")
          << "," << fmt(r.model_vs_truth.peak, "%.4g") << "," << fmt(r.model_vs_truth.impulse, "%.4g")
          << "," << fmt(o.precompute_seconds, "%.4g") << "," << fmt(1e3 * o.fem_step_seconds, "%.4g")
          << "," << fmt(1e6 * o.irdm_force_loop_seconds, "%.4g") << "\n";
      return csv.str();
    }

    /// The report's two tables' rows.
    void
    table_rows(const Row &r, std::string &method, std::string &discretization)
    {
      const Outcome     &o    = r.run;
      const std::string  disc = fs::path(o.d.mesh_file).stem().string() + " P" + std::to_string(o.d.degree);
      method += "| " + r.scene + " | " + disc + " | " + std::to_string(o.free_dofs) + " | " +
                std::to_string(o.modes) +
                (o.sparse ? " (" + std::to_string(o.lowest) + " lowest)" : " (all)") + " | " +
                fmt(r.method.rel_l2) + " | " + fmt(r.method.peak) + " | " + fmt(r.method.impulse) +
                " | " + fmt(r.method_disp_rms) + " | " + fmt(o.precompute_seconds) + " | " +
                fmt(1e3 * o.fem_step_seconds) + " | " + fmt(1e6 * o.irdm_force_loop_seconds) + " |\n";
      discretization += "| " + r.scene + " | " + disc + " | " + fmt(o.stiffness, "%.4g") + " | " +
                        (std::isnan(r.vs_extrapolated) ? "" : pct(r.vs_extrapolated)) + " | " +
                        (r.is_truth ? "(the truth)" : pct(r.fem_vs_truth.rel_l2)) + " | " +
                        (r.is_truth ? "" : pct(r.fem_vs_truth.peak)) + " | " +
                        (r.is_truth ? "" : pct(r.fem_vs_truth.impulse)) + " | " +
                        pct(r.model_vs_truth.rel_l2) + " | " + pct(r.model_vs_truth.peak) + " | " +
                        pct(r.model_vs_truth.impulse) + " |\n";
    }

    void
    write_report(const std::string &dir, const ConvergedValidationOptions &o,
                 const Discretization &converged, const std::vector<Row> &rows,
                 const std::string &series)
    {
      std::string csv = "scene,discretization,mesh,fe_degree,free_dofs,patch_vertices,stiffness_N_m,"
                        "stiffness_vs_extrapolated,model_inputs,model_modes,model_lowest_modes,"
                        "method_force_error,method_peak_error,method_impulse_error,method_disp_rms,"
                        "fem_vs_converged_force_error,fem_vs_converged_peak_error,"
                        "fem_vs_converged_impulse_error,model_vs_converged_force_error,"
                        "model_vs_converged_peak_error,model_vs_converged_impulse_error,precompute_s,"
                        "fem_ms_per_step,irdm_us_per_step\n";
      std::string method, discretization;
      for (const auto &r : rows)
        {
          csv += csv_row(r);
          table_rows(r, method, discretization);
        }
      const TemplateValues v{
        {"stamp", report_stamp()},
        {"radius_mm", plain(o.probe_radius * 1e3)},
        {"converged_mesh", fs::path(converged.mesh_file).filename().string()},
        {"converged_degree", std::to_string(converged.degree)},
        {"modes", std::to_string(o.modes)},
        {"extrapolated", o.extrapolated_stiffness > 0 ? "1" : ""},
        {"extrapolated_scene", o.extrapolated_scene},
        {"extrapolated_stiffness", fmt(o.extrapolated_stiffness, "%.5g")},
        {"method_table", method},
        {"discretization_table", discretization}};
      write_text_file((fs::path(dir) / "converged.csv").string(), csv);
      write_text_file((fs::path(dir) / "series.csv").string(),
                      "scene,t_s,probe,fem_coarse_N,irdm_coarse_N,fem_converged_N,irdm_converged_N\n" +
                        series);
      write_text_file((fs::path(dir) / "report.md").string(),
                      fill_template(read_template("validation/templates/converged.md"), v));
    }
  } // namespace

  void
  run_converged_validation(const ConvergedValidationOptions &o, std::ostream &log)
  {
    if (o.converged_mesh.empty())
      throw InputError("validate-converged: --converged-mesh is required");
    if (!(o.probe_radius > 0))
      throw InputError("validate-converged: --radius must be > 0 m");
    const std::string dir = (fs::path(o.report_dir) / "converged").string();
    fs::create_directories(dir);
    fs::create_directories(o.model_dir);
    const OutputLock report_lock((fs::path(dir) / "converged.csv").string());
    const OutputLock models_lock((fs::path(o.model_dir) / "converged").string());
    const Discretization converged{"converged", fs::absolute(o.converged_mesh).string(),
                                   o.converged_degree};
    unsigned                      length = 1;
    const std::vector<fem::Scene> scenes = read_scenes(o, length);
    const auto                    same_probe = extrapolated_probe_test(o);
    std::map<std::string, CachedModel> models;
    std::vector<Row>                   rows;
    std::string                        series;
    for (const fem::Scene &base : scenes)
      {
        log << "== " << base.name << ": " << base.n_steps() << " steps of " << base.time_step
            << " s, probes of radius " << o.probe_radius << " m" << std::endl;
        const Discretization coarse{"coarse", base.mesh_file, base.fe_degree};
        std::vector<Outcome> runs;
        runs.push_back(run_one(base, coarse, o, length, models, log));
        runs.push_back(run_one(base, converged, o, length, models, log));
        const Series &truth = runs.back().fem;
        std::vector<Row> scored;
        for (const auto &r : runs)
          scored.push_back({base.name, {}, force_errors(r.irdm, r.fem), force_errors(r.fem, truth),
                            force_errors(r.irdm, truth), compare(r.irdm, r.fem).disp_rms,
                            same_probe(base) ? r.stiffness / o.extrapolated_stiffness - 1 : NAN,
                            &r == &runs.back()});
        series += series_rows(base, runs);
        for (size_t i = 0; i < runs.size(); ++i)
          {
            runs[i].fem = runs[i].irdm = Series(); // the figures are kept; the series are large
            scored[i].run = std::move(runs[i]);
            rows.push_back(std::move(scored[i]));
          }
      }
    for (const auto &m : models)
      fs::remove(m.second.path);
    write_report(dir, o, converged, rows, series);
    log << "report: " << dir << "/report.md\n";
  }
} // namespace irdm::validation
