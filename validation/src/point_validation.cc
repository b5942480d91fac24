// IRDM point-interaction validation against the reference FEM. Data flow: scene -> FEM run
// (ground truth) and precompute -> model file -> IRDM runtime -> comparison -> report.
#include <irdm_common/format.h>
#include <irdm_common/report_stamp.h>
#include <irdm_common/files.h>
#include <irdm/model.h>
#include <irdm/modal_model.h>
#include <irdm/point_interaction.h>
#include <irdm/representative_interaction.h>
#include <irdm/representative_model.h>
#include <irdm_common/csv.h>
#include <irdm_common/error.h>
#include <irdm_common/h5.h>
#include <irdm_common/geometry.h>
#include <reference_fem/elastodynamics.h>
#include <reference_fem/impulse_response.h>
#include <validation/point_validation.h>

#include "compression_study.h"
#include "scene_runs.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>

namespace fs = std::filesystem;

namespace irdm::validation
{
  namespace
  {
    // validate writes its working models into --models and removes each after use: a file
    // already there is someone's, and is never overwritten or removed.
    void
    refuse_existing_model(const std::string &path)
    {
      if (!fs::exists(path))
        return;
      // A model irdm made is most likely the working model of a validate run that was stopped
      // before it removed it: say so, and how to clear it.
      bool ours = false;
      try
        {
          const h5::Reader r(path);
          ours = r.has_attribute("/", "format") &&
                 r.string_attribute("/", "format") == "irdm-impulse-response";
        }
      catch (const InputError &)
        {}
      if (ours)
        throw InputError("'" + path + "' is an irdm model, most likely the working model of an "
                         "earlier validate run that was stopped before it removed it; validate "
                         "never touches a file already in --models: remove it (rm '" + path +
                         "') and run again, or choose another --models folder");
      throw InputError("'" + path + "' exists; validate writes its working models to --models "
                       "and removes them after use, so it never touches a file already there: "
                       "move it or choose another --models folder");
    }


    // The uncompressed model, all taps or the first `taps`.
    Series
    run_direct(const fem::Scene &scene, const ImpulseResponseModel &model, const unsigned taps,
               const bool with_surface)
    {
      PointInteraction irdm(model, taps);
      return run_irdm(scene, model, irdm, with_surface);
    }

    // The time-step study's scene: the contact phase only (until the first probe's depth first
    // returns to 0 after pushing), with bilateral probes. A unilateral vertex contact on an
    // implicit integrator switches on and off between steps (chatter), and at tau/10 that
    // switching does not converge (the report shows it), so it cannot serve as ground truth.
    fem::Scene
    contact_phase(const fem::Scene &scene)
    {
      fem::Scene c = scene;
      double     end = scene.duration;
      for (auto &p : c.probes)
        {
          p.unilateral       = false;
          end                = std::min(end, p.until);
          const auto &t = p.depth.times, &v = p.depth.values;
          bool pushed = false;
          for (size_t i = 0; i < t.size(); ++i)
            {
              if (v[i] > 0)
                pushed = true;
              else if (pushed && i > 0)
                {
                  end = std::min(end, t[i - 1] + (0 - v[i - 1]) / (v[i] - v[i - 1]) * (t[i] - t[i - 1]));
                  break;
                }
            }
        }
      c.duration = std::max(1.0, std::floor(end / scene.time_step)) * scene.time_step;
      return c;
    }

    // The scene's "comment", for the report's first paragraph.
    std::string
    scene_comment(const std::string &file)
    {
      std::ifstream in(file);
      std::stringstream b;
      b << in.rdbuf();
      const std::string text = b.str();
      const auto        at   = text.find("\"comment\"");
      if (at == std::string::npos)
        return "";
      const auto q0 = text.find('"', text.find(':', at) + 1);
      const auto q1 = text.find('"', q0 + 1);
      return q0 == std::string::npos || q1 == std::string::npos ? "" : text.substr(q0 + 1, q1 - q0 - 1);
    }

    /// The passivity observer of each run (scene_runs.h): what the device put in, and the most
    /// the body gave back at any time.
    std::string
    passivity_section(const fem::Scene &scene,
                      const std::vector<std::pair<std::string, const Series *>> &runs)
    {
      std::ostringstream md;
      md << "Passivity: the work W(n) = sum f . dx the device did on the body up to step n "
            "(x the device's displacement, the probe's depth along its direction). A passive "
            "contact never gives back more than it took (max -W = 0). Probes: ";
      for (const auto &p : scene.probes)
        md << "`" << p.name << "` "
           << (p.coupling_stiffness > 0 || p.coupling_damping > 0
                 ? "coupled (k = " + fmt(p.coupling_stiffness) + " N/m, b = " +
                     fmt(p.coupling_damping) + " N s/m)"
                 : std::string("rigid"))
           << (p.unilateral ? ", unilateral" : ", bilateral") << "; ";
      md << "\n\n| run | device work at the end (J) | most given back, max -W (J) |\n"
            "|---|---|---|\n";
      for (const auto &[name, series] : runs)
        md << "| " << name << " | " << fmt(series->device_work) << " | "
           << fmt(series->device_returned) << " |\n";
      md << "\n";
      return md.str();
    }

    /// Virtual coupling's stable region on a scene with a coupled probe: every probe coupled
    /// at stiffness x {0.1 .. 100} and damping x {0, 1, 10} of the scene's own, and rigid;
    /// IRDM at tau (exact against the FEM at tau) and the FEM at tau/10. Writes coupling.csv
    /// and returns the report section.
    std::string
    coupling_sweep(const fem::Scene &scene, const ImpulseResponseModel &model,
                   const double fem_peak, const fs::path &dir, const std::string &fine_model_file,
                   std::ostream &log)
    {
      double k0 = 0, b0 = 0;
      for (const auto &p : scene.probes)
        k0 = std::max(k0, p.coupling_stiffness), b0 = std::max(b0, p.coupling_damping);
      struct Run
      {
        double k, b, tau;
        std::string solver;
        Series      s;
      };
      std::vector<Run> runs;
      const unsigned   N = scene.n_steps();
      const auto       add = [&](const double k, const double b) {
        fem::Scene c = scene;
        for (auto &p : c.probes)
          p.coupling_stiffness = k, p.coupling_damping = b;
        PointInteraction irdm(model);
        runs.push_back({k, b, scene.time_step, "irdm", run_irdm(c, model, irdm, false, 100 * fem_peak)});
        runs.push_back({k, b, scene.time_step / 10, "fem", run_fem(c, model, 10, N)});
      };
      log << "  coupling sweep" << std::flush;
      add(0, 0);
      const std::vector<double> k_factors = {0.1, 0.3, 1, 3, 10, 100}, b_factors = {0, 1, 10};
      for (const double fk : k_factors)
        for (const double fb : b_factors)
          {
            add(fk * k0, fb * b0);
            log << "." << std::flush;
          }
      log << "\n";
      std::ostringstream csv;
      csv << "stiffness_N_m,damping_N_s_m,time_step_s,solver,peak_force_N,device_work_J,"
             "device_work_max_J,device_returned_J,bounded,passive\n";
      const auto bounded = [&](const Run &r) {
        return r.s.diverged_at < 0 && peak_force(r.s) <= 100 * fem_peak && std::isfinite(peak_force(r.s));
      };
      // Passive: gives back at most 1e-6 of what it took (round-off of the observer's sum).
      const auto passive = [&](const Run &r) {
        return bounded(r) && r.s.device_returned <= 1e-6 * r.s.device_work_max;
      };
      for (const auto &r : runs)
        csv << r.k << "," << r.b << "," << r.tau << "," << r.solver << "," << peak_force(r.s)
            << "," << r.s.device_work << "," << r.s.device_work_max << "," << r.s.device_returned
            << "," << bounded(r) << "," << passive(r) << "\n";
      write_text_file((dir / "coupling.csv").string(), csv.str());

      std::ostringstream md;
      md << "## (f) Virtual coupling: the stable region\n\n"
         << "Every probe coupled to its device by a spring k and a damper b (contact::Coupling, "
            "solved implicitly through the feed-through; unilateral on the coupled force), "
            "around the scene's own k0 = " << fmt(k0) << " N/m, b0 = " << fmt(b0)
         << " N s/m. IRDM at tau = " << scene.time_step
         << " s (exact against the FEM at tau), the FEM at tau/10. Each cell: peak force (N), "
            "and the most energy the body gave back to the device, max -W (J); **P** passive "
            "(max -W <= 1e-6 of the work put in), **B** bounded but not passive, **D** "
            "diverged (force beyond 100 x the FEM's peak at tau, " << fmt(fem_peak)
         << " N). CSV: `coupling.csv`.\n\n| k (N/m) | b (N s/m) | IRDM at tau | FEM at tau/10 "
            "|\n|---|---|---|---|\n";
      const auto cell = [&](const Run &r) {
        return std::string(passive(r) ? "**P**" : bounded(r) ? "**B**" : "**D**") + " " +
               fmt(peak_force(r.s)) + " N, " + fmt(r.s.device_returned) + " J";
      };
      for (size_t i = 0; i + 1 < runs.size(); i += 2)
        md << "| " << (runs[i].k == 0 && runs[i].b == 0 ? "rigid" : fmt(runs[i].k)) << " | "
           << (runs[i].k == 0 && runs[i].b == 0 ? "-" : fmt(runs[i].b)) << " | " << cell(runs[i])
           << " | " << cell(runs[i + 1]) << " |\n";
      md << "\n";

      // IRDM at tau/10 too, from a model precomputed at tau/10 whose outputs are its inputs
      // (the probe's region: the force loop needs no more), against the FEM at tau/10 with the
      // same coupling: the scene's own coupling and the rigid probe.
      fem::Scene fine = scene;
      fine.time_step /= 10;
      fine.model.outputs = fine.model.inputs;
      refuse_existing_model(fine_model_file);
      fem::PrecomputeOptions po;
      po.output = fine_model_file;
      po.length = fine.n_steps();
      fem::precompute_impulse_responses(fine, po);
      const ImpulseResponseModel fine_model = load_model(fine_model_file, fine.time_step);
      md << "At tau/10 = " << fine.time_step << " s, IRDM from a model precomputed at that step "
         << "(outputs: its inputs, " << fine_model.n_inputs / 3 << " vertices; T = "
         << fine_model.length << ") against the FEM at the same step and coupling:\n\n"
         << "| probe | IRDM at tau/10 | FEM at tau/10 | force rel. L2, IRDM against FEM |\n"
            "|---|---|---|---|\n";
      for (const bool rigid : {false, true})
        {
          fem::Scene c = fine;
          if (rigid)
            for (auto &p : c.probes)
              p.coupling_stiffness = p.coupling_damping = 0;
          PointInteraction irdm(fine_model);
          Run a{k0, b0, c.time_step, "irdm", run_irdm(c, fine_model, irdm, false, 100 * fem_peak)};
          Run f{k0, b0, c.time_step, "fem", run_fem(c, fine_model, 1, c.n_steps())};
          md << "| " << (rigid ? "rigid" : "coupled (k0, b0)") << " | " << cell(a) << " | "
             << cell(f) << " | "
             << (a.s.diverged_at >= 0 ? "(IRDM stopped at t = " + fmt(a.s.diverged_at) + " s)"
                                      : fmt(compare(a.s, f.s).force_rel_l2))
             << " |\n";
        }
      fs::remove(fine_model_file);
      md << "\n";
      return md.str();
    }
  } // namespace

  namespace
  {
    // Per scene and compressor: the smallest model that meets the goal (disp. RMS
    // <= 1 %, force rel. L2 <= 2 %, stable), and the unstable settings.
    std::string
    compression_summary(
      const std::vector<std::pair<std::string, std::vector<CompressionRow>>> &scenes)
    {
      std::ostringstream md;
      md << "## Compression (issue 4): the smallest model meeting disp. RMS <= 1 % and force "
            "rel. L2 <= 2 % in closed loop\n\n"
         << "| scene | method | smallest setting meeting the goal | % of float H | disp. RMS | "
            "force rel. L2 | force loop us | full update us | unstable settings |\n"
            "|---|---|---|---|---|---|---|---|---|\n";
      for (const auto &[name, rows] : scenes)
        for (const char *method : {"representatives", "interpolated", "modal"})
          {
            const CompressionRow *best = nullptr;
            std::string           unstable;
            for (const auto &r : rows)
              {
                if (r.method != method)
                  continue;
                if (!r.stable)
                  unstable += (unstable.empty() ? "" : "; ") + r.setting;
                if (r.stable && r.errors.disp_rms <= 0.01 && r.errors.force_rel_l2 <= 0.02 &&
                    (!best || r.bytes < best->bytes))
                  best = &r;
              }
            md << "| " << name << " | " << method << " | ";
            if (best)
              md << best->setting << " | " << fmt(best->percent) << " | " << fmt(best->errors.disp_rms)
                 << " | " << fmt(best->errors.force_rel_l2) << " | " << fmt(best->force_loop_us)
                 << " | " << fmt(best->surface_us);
            else
              md << "none | - | - | - | - | -";
            md << " | " << (unstable.empty() ? "none" : unstable) << " |\n";
          }
      md << "\nEvery setting, its time per step and the charts: section (e) of each scene's "
            "report.\n\n";
      return md.str();
    }
  } // namespace

  bool
  run_point_validation(const PointValidationOptions &o, std::ostream &log)
  {
    std::vector<std::string> files;
    if (!fs::is_directory(o.scenes_dir))
      throw InputError("scene folder '" + o.scenes_dir + "' does not exist");
    for (const auto &e : fs::directory_iterator(o.scenes_dir))
      if (e.path().extension() == ".json")
        files.push_back(e.path().string());
    std::sort(files.begin(), files.end());
    fs::create_directories(o.model_dir);
    fs::create_directories(o.report_dir);

    std::ostringstream summary;
    summary << "| scene | steps | probes | model (in x out x T) | precompute s | model MB | "
               "force rel. L2 | force max | disp. RMS | disp. max | float: force L2 / disp. max "
               "| IRDM force loop us/step | IRDM full update us/step | FEM ms/step |\n"
               "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n";
    bool all_exact = true;
    int  ran       = 0;
    std::vector<std::pair<std::string, std::vector<CompressionRow>>> comp_rows;
    for (const auto &file : files)
      {
        const fem::Scene scene = fem::read_scene(file);
        if (!o.only.empty() && std::find(o.only.begin(), o.only.end(), scene.name) == o.only.end())
          continue;
        if (scene.probes.empty())
          throw InputError("scene '" + file + "' has no probes: nothing to validate");
        if (!(scene.duration > 0))
          throw InputError("scene '" + file + "' gives no time.duration_s");
        ++ran;
        const unsigned N = scene.n_steps();
        log << "== " << scene.name << ": " << N << " steps of " << scene.time_step << " s\n";

        // 1. Model (restricted to the scene's touched region; T >= N so nothing truncates).
        fem::PrecomputeOptions po;
        po.output  = (fs::path(o.model_dir) / (scene.name + ".h5")).string();
        refuse_existing_model(po.output);
        po.length  = std::max(o.length.value_or(scene.model.length), N);
        po.restart = true;
        const auto pre = fem::precompute_impulse_responses(scene, po);
        const ImpulseResponseModel model = load_model(po.output, scene.time_step);
        log << "  model " << model.n_outputs << " x " << model.n_inputs << " x " << model.length
            << " in " << fmt(pre.seconds_total) << " s, " << fmt(pre.bytes / 1e6) << " MB\n";

        // 2. Ground truth, and the FEM at tau / 10.
        const Series fem_run  = run_fem(scene, model, 1, N);
        // Unilateral contact at tau/10: does it stay bounded? (diagnostic, see contact_phase)
        const Series fem_fine_unilateral = run_fem(scene, model, 10, N);
        double       peak_coarse = 0, peak_fine = 0;
        bool         fine_finite = true;
        for (size_t p = 0; p < scene.probes.size(); ++p)
          for (unsigned k = 0; k < N; ++k)
            {
              peak_fine = std::max(peak_fine, norm(fem_fine_unilateral.force[p][k]));
              fine_finite = fine_finite && std::isfinite(norm(fem_fine_unilateral.force[p][k]));
            }
        log << "  FEM " << fmt(1e3 * fem_run.step_seconds) << " ms/step\n";

        // 3. IRDM: exact (all taps, double), float, truncated; cost.
        for (size_t p = 0; p < scene.probes.size(); ++p)
          for (unsigned k = 0; k < N; ++k)
            peak_coarse = std::max(peak_coarse, norm(fem_run.force[p][k]));
        const Series irdm_full  = run_direct(scene, model, 0, true);
        const Errors exact      = compare(irdm_full, fem_run);
        // The float copy lives only for this run: the compression study makes its own, and
        // holding both would raise the peak by half the model.
        const Errors exact_f = compare(run_direct(scene, model.as_float(), 0, true), fem_run);
        const Series irdm_force = run_direct(scene, model, 0, false); // force loop alone
        const bool   pass       = exact.force_rel_l2 < 1e-9 && exact.disp_max < 1e-9;
        all_exact               = all_exact && pass;
        log << "  exactness: force rel. L2 " << fmt(exact.force_rel_l2) << ", disp. max "
            << fmt(exact.disp_max) << (pass ? " (pass)" : " (FAIL: above 1e-9)") << "\n";

        std::vector<unsigned> taps_list;
        for (const unsigned T : {50u, 100u, 200u, 300u, 500u, 750u, 1000u})
          if (T <= model.length)
            taps_list.push_back(T);
        std::vector<Errors> trunc;
        for (const unsigned T : taps_list)
          trunc.push_back(compare(run_direct(scene, model, T, true), fem_run));

        const fem::Scene phase      = contact_phase(scene);
        const unsigned   Nc         = phase.n_steps();
        const Series     phase_fem  = run_fem(phase, model, 1, Nc);
        const Series     phase_fine = run_fem(phase, model, 10, Nc);
        const Series     phase_irdm = run_direct(phase, model, 0, true);
        const Errors     step_irdm  = compare(phase_irdm, phase_fine);
        const Errors     step_fem   = compare(phase_fem, phase_fine);
        {
          std::vector<std::string>          header = {"time_s"};
          std::vector<std::vector<double>> cols(1);
          for (unsigned k = 1; k <= Nc; ++k)
            cols[0].push_back(k * scene.time_step);
          for (size_t p = 0; p < scene.probes.size(); ++p)
            for (const auto &[tag, series] :
                 {std::pair<std::string, const Series *>{"irdm", &phase_irdm}, {"fem_fine", &phase_fine}})
              {
                header.push_back(scene.probes[p].name + "_" + tag + "_force_N");
                cols.emplace_back();
                for (unsigned k = 0; k < Nc; ++k)
                  cols.back().push_back(norm(series->force[p][k]));
              }
          header.push_back("disp_rms_error_rel");
          cols.push_back(step_irdm.disp_rms_t);
          fs::create_directories(fs::path(o.report_dir) / scene.name);
          write_csv((fs::path(o.report_dir) / scene.name / "timestep.csv").string(), header, cols);
        }

        // 3b. Compression: every compressor in closed loop against the same FEM run.
        const auto comp = compression_study(scene, model, fem_run, log);
        comp_rows.push_back({scene.name, comp});

        // 4. Report files.
        const fs::path dir = fs::path(o.report_dir) / scene.name;
        fs::create_directories(dir);
        bool coupled = false;
        for (const auto &p : scene.probes)
          coupled = coupled || p.coupling_stiffness > 0 || p.coupling_damping > 0;
        const std::string sweep_md =
          coupled ? coupling_sweep(scene, model, peak_coarse, dir,
                                   (fs::path(o.model_dir) / (scene.name + "_tau10.h5")).string(), log)
                  : std::string();
        {
          std::vector<std::string>          header = {"time_s"};
          std::vector<std::vector<double>> cols(1);
          for (unsigned k = 1; k <= N; ++k)
            cols[0].push_back(k * scene.time_step);
          for (size_t p = 0; p < scene.probes.size(); ++p)
            for (const auto &[tag, series] :
                 {std::pair<std::string, const Series *>{"fem", &fem_run}, {"irdm", &irdm_full}})
              for (int c = 0; c < 3; ++c)
                {
                  header.push_back(scene.probes[p].name + "_" + tag + "_F" + "xyz"[c] + "_N");
                  cols.emplace_back();
                  for (unsigned k = 0; k < N; ++k)
                    cols.back().push_back(series->force[p][k][c]);
                }
          header.push_back("force_error_rel");
          cols.push_back(exact.force_t);
          header.push_back("disp_rms_error_rel");
          cols.push_back(exact.disp_rms_t);
          header.push_back("disp_rms_error_rel_float");
          cols.push_back(exact_f.disp_rms_t);
          header.push_back("force_error_rel_T500");
          cols.push_back(std::find(taps_list.begin(), taps_list.end(), 500u) != taps_list.end()
                           ? trunc[std::find(taps_list.begin(), taps_list.end(), 500u) - taps_list.begin()].force_t
                           : std::vector<double>(N, 0.0));
          write_csv((dir / "series.csv").string(), header, cols);
        }
        {
          std::vector<std::vector<double>> cols(5);
          for (size_t i = 0; i < taps_list.size(); ++i)
            {
              cols[0].push_back(taps_list[i]);
              cols[1].push_back(trunc[i].force_rel_l2);
              cols[2].push_back(trunc[i].force_max);
              cols[3].push_back(trunc[i].disp_rms);
              cols[4].push_back(trunc[i].disp_max);
            }
          write_csv((dir / "truncation.csv").string(),
                    {"T_steps", "force_rel_l2", "force_max_rel", "disp_rms_rel", "disp_max_rel"},
                    cols);
        }
        std::ostringstream md;
        md << "# Validation scene `" << scene.name << "`\n\n"
           << report_stamp() << "\n\n"
           << scene_comment(file) << "\n\n"
           << "Generated by `irdm validate` (IRDM " << IRDM_VERSION << "). Scene: `" << file
           << "`. FEM: P" << scene.fe_degree << ", " << pre.n_free << " free DoFs, Newmark, tau = "
           << scene.time_step << " s, " << N << " steps. Material E = " << scene.youngs_modulus
           << " Pa, nu = " << scene.poisson_ratio << ", rho = " << scene.density
           << " kg/m^3; Rayleigh alpha = " << fmt(scene.rayleigh_alpha) << " 1/s, beta = "
           << fmt(scene.rayleigh_beta) << " s (lowest mode " << fmt(pre.lowest_frequency_hz)
           << " Hz; lowest modal damping ratio " << fmt(pre.lowest_damping_ratio) << ").\n\n"
           << "Errors: force relative L2 = ||F_IRDM - F_FEM||_2 / ||F_FEM||_2 over all probes and "
              "steps; force max = max |dF| / max |F_FEM|; displacement RMS and max over all model "
              "output vertices and steps, relative to the peak FEM displacement of any output "
              "vertex.\n\n"
           << "## Model (restricted to the touched region)\n\n"
           << "| inputs (DoFs) | outputs (DoFs) | T | storage | size MB | precompute s "
              "(FEM / modes / responses / write) | energy left after T (mean / max) | static "
              "compliance beyond T (mean / max) |\n"
              "|---|---|---|---|---|---|---|---|\n"
           << "| " << pre.n_inputs << " | " << pre.n_outputs << " | " << pre.length
           << " | double | " << fmt(pre.bytes / 1e6) << " | " << fmt(pre.seconds_total) << " ("
           << fmt(pre.seconds_fem) << " / " << fmt(pre.seconds_eigen) << " / "
           << fmt(pre.seconds_responses) << " / " << fmt(pre.seconds_write) << ") | "
           << fmt(pre.energy_left_mean) << " / " << fmt(pre.energy_left_max) << " | "
           << fmt(pre.static_left_mean) << " / " << fmt(pre.static_left_max) << " |\n\n"
           << "With T = 500 (the seed's 1 s) the same model would leave: see the truncation "
              "table below.\n\n"
           << "## (a) Exactness: untruncated, uncompressed IRDM against the FEM at the same tau\n\n"
           << "| storage | force rel. L2 | force max | disp. RMS | disp. max |\n|---|---|---|---|---|\n"
           << "| double | " << fmt(exact.force_rel_l2) << " | " << fmt(exact.force_max) << " | "
           << fmt(exact.disp_rms) << " | " << fmt(exact.disp_max) << " |\n"
           << "| float | " << fmt(exact_f.force_rel_l2) << " | " << fmt(exact_f.force_max) << " | "
           << fmt(exact_f.disp_rms) << " | " << fmt(exact_f.disp_max) << " |\n\n"
           << "Check: double within 1e-9: **" << (pass ? "pass" : "FAIL") << "**.\n\n"
           << "![force](force.png)\n\n![error](error.png)\n\n"
           << "## (b) Truncation: error against T (responses cut after T samples)\n\n"
           << "| T (steps) | T (s) | force rel. L2 | force max | disp. RMS | disp. max |\n"
              "|---|---|---|---|---|---|\n";
        for (size_t i = 0; i < taps_list.size(); ++i)
          md << "| " << taps_list[i] << " | " << fmt(taps_list[i] * scene.time_step) << " | "
             << fmt(trunc[i].force_rel_l2) << " | " << fmt(trunc[i].force_max) << " | "
             << fmt(trunc[i].disp_rms) << " | " << fmt(trunc[i].disp_max) << " |\n";
        md << "\n![truncation](truncation.png)\n\n"
           << "## (c) Time step: against the FEM at tau/10 = " << scene.time_step / 10
           << " s (converged ground truth)\n\n"
           << "Over the contact phase (0 to " << phase.duration << " s, " << Nc
           << " steps, until a probe first lets go) with the probes held bilateral, so that "
              "contact switching does not enter. Fine-step forces are averaged over each tau "
              "(impulse per step / tau).\n\n"
           << "| run at tau = " << scene.time_step << " s | force rel. L2 | force max | disp. RMS | disp. max |\n"
              "|---|---|---|---|---|\n"
           << "| IRDM | " << fmt(step_irdm.force_rel_l2) << " | " << fmt(step_irdm.force_max) << " | "
           << fmt(step_irdm.disp_rms) << " | " << fmt(step_irdm.disp_max) << " |\n"
           << "| FEM | " << fmt(step_fem.force_rel_l2) << " | " << fmt(step_fem.force_max) << " | "
           << fmt(step_fem.disp_rms) << " | " << fmt(step_fem.disp_max) << " |\n\n"
           << "The two rows agree because IRDM reproduces the FEM at tau exactly: this is what "
              "the 2 ms sampling itself costs.\n\n![time step](timestep.png)\n\n"
           << "The whole scene with its own contact rules (unilateral probes included), FEM at "
              "tau/10: peak force "
           << fmt(peak_fine) << " N against " << fmt(peak_coarse) << " N at tau"
           << (!fine_finite || peak_fine > 100 * peak_coarse
                 ? " (**the run diverged**: forces grow without bound)"
                 : "")
           << ". A unilateral contact imposed on one surface point of an implicit integrator "
              "switches on and off from step to step (chatter: the pushed vertex overshoots the "
              "probe); IRDM reproduces that exactly at tau, but it is not a converged quantity "
              "as tau shrinks.\n\n"
           << passivity_section(scene, {{"FEM at tau", &fem_run}, {"IRDM at tau", &irdm_full},
                                        {"FEM at tau/10", &fem_fine_unilateral}})
           << "## (d) Cost per step, measured in the same run (wall clock, one core)\n\n"
           << "| IRDM force loop | IRDM full surface update (" << model.n_outputs / 3
           << " vertices) | FEM step (P" << scene.fe_degree << ", MUMPS) |\n|---|---|---|\n"
           << "| " << fmt(1e6 * irdm_force.force_loop_seconds) << " us | "
           << fmt(1e6 * irdm_full.surface_seconds) << " us | " << fmt(1e3 * fem_run.step_seconds)
           << " ms |\n\n"
           << "The IRDM costs grow with the number of inputs that carry force inside the window "
              "T (direct convolution, no compression). CSV: `series.csv`, `truncation.csv`.\n\n"
           << "## (e) Compression: every compressor in closed loop on this scene\n\n"
           << "Representative waveforms (seed 000 section 3; plain substitution and interpolation "
              "among 3 nearby representatives) at each theta, and the modal realization with M "
              "modes and L = 2 residual taps (docs/compression.md), each run through the whole "
              "scene in closed loop (prescribed displacement, computed force) and compared with "
              "the FEM run of (a). Memory relative to this model's H stored as float ("
           << fmt(4.0 * model.n_inputs * model.n_outputs * model.length / 1e6)
           << " MB). Times per step measured in this run, one core. A run whose force exceeds "
              "10 times the FEM's peak is stopped and marked unstable.\n\n"
           << compression_section(comp, model.n_outputs)
           << "\n![speed against accuracy](speed_accuracy.png)\n\n![memory against "
              "accuracy](memory_accuracy.png)\n\nCSV: `compression.csv`.\n";
        write_compression_csv((dir / "compression.csv").string(), comp);
        md << sweep_md;
        write_text_file((dir / "report.md").string(), md.str());
        summary << "| [" << scene.name << "](" << scene.name << "/report.md) | " << N << " | "
                << scene.probes.size() << " | " << pre.n_inputs << " x " << pre.n_outputs
                << " x " << pre.length << " | " << fmt(pre.seconds_total) << " | "
                << fmt(pre.bytes / 1e6) << " | " << fmt(exact.force_rel_l2) << " | "
                << fmt(exact.force_max) << " | " << fmt(exact.disp_rms) << " | "
                << fmt(exact.disp_max) << " | " << fmt(exact_f.force_rel_l2) << " / "
                << fmt(exact_f.disp_max) << " | " << fmt(1e6 * irdm_force.force_loop_seconds)
                << " | " << fmt(1e6 * irdm_full.surface_seconds) << " | "
                << fmt(1e3 * fem_run.step_seconds) << " |\n";
        if (!o.plot_script.empty())
          {
            const std::string cmd = "/usr/bin/python3 '" + o.plot_script + "' '" + dir.string() + "'";
            if (std::system(cmd.c_str()) != 0)
              log << "  note: charts not drawn (python3-matplotlib missing?)\n";
          }
        fs::remove(po.output); // models are large; the report keeps their figures
      }
    if (ran == 0)
      throw InputError("no scene to run in '" + o.scenes_dir + "'");

    std::ostringstream full;
    if (o.full_model)
      {
        // The full cat model: every free surface DoF in and out, T = 500, float.
        fem::Scene s = fem::read_scene(files.front());
        fem::PrecomputeOptions po;
        po.input_stride  = o.full_model_stride;
        po.inputs_always = s.model.inputs; // the scene's probes must touch inputs
        s.model          = {};
        po.output  = (fs::path(o.model_dir) / "full.h5").string();
        refuse_existing_model(po.output);
        po.restart = true;
        po.log     = [&](const std::string &l) {
          if (l.rfind("chunk", 0) != 0)
            log << "  full model: " << l << "\n";
        };
        const auto r = fem::precompute_impulse_responses(s, po);
        const std::string inputs_are =
          o.full_model_stride > 1
            ? "Every free surface vertex DoF out; in, a sample: every " +
                std::to_string(o.full_model_stride) + "th free surface vertex plus the scene's "
                "touched region (`irdm validate --full-model-stride`; the compression is per "
                "input, so its ratios and fits estimate the whole model's, while sizes and "
                "times are the sample's). T = "
            : std::string("Every free surface vertex DoF in and out, T = ");
        full << "## Full model of the cat\n\n" << inputs_are << r.length << ", float: " << r.n_inputs << " x " << r.n_outputs << " x " << r.length
             << " = " << fmt(r.bytes / 1e6) << " MB, precomputed in " << fmt(r.seconds_total)
             << " s (FEM " << fmt(r.seconds_fem) << " s, all " << r.n_free << " modes "
             << fmt(r.seconds_eigen) << " s, responses (GEMM) " << fmt(r.seconds_responses)
             << " s, HDF5 write " << fmt(r.seconds_write) << " s), " << r.ranks
             << " rank(s). Energy left after T: mean " << fmt(r.energy_left_mean) << ", max "
             << fmt(r.energy_left_max) << "; driving-point static compliance beyond T: mean "
             << fmt(r.static_left_mean) << ", max " << fmt(r.static_left_max) << ".\n\n";
      
        // Table 1 of seed 000 for this cat, and the same runtimes on the full model: the
        // scene's probes driving every surface input's model (T = 500, so the errors against
        // the FEM include the truncation of section (b); they are given for completeness).
        log << "  full model: loading for the compression table\n";
        const ImpulseResponseModel full_model = load_model(po.output, s.time_step);
        fs::remove(po.output);
        const double waveforms = double(full_model.n_inputs) * full_model.n_outputs;
        const double h_bytes   = 4.0 * waveforms * full_model.length;
        const Series fem_full  = run_fem(s, full_model, 1, s.n_steps());
        const double bound     = 10 * peak_force(fem_full);
        std::ostringstream table1, timing;
        table1 << "| threshold of correlation coefficient | 0.80 | 0.85 | 0.90 | 0.95 | original |\n"
                  "|---|---|---|---|---|---|\n";
        std::vector<std::string> cells[7];
        std::vector<CompressionRow> full_rows;
        const auto row_of = [&](const std::string &method, const std::string &setting,
                                const double bytes, const double build_seconds, const Series &run) {
          CompressionRow row = measured_row(run, fem_full);
          row.method         = method;
          row.setting        = setting;
          row.bytes          = bytes;
          row.percent        = 100 * bytes / h_bytes;
          row.build_seconds  = build_seconds;
          return row;
        };
        {
          PointInteraction direct(full_model);
          full_rows.push_back(row_of("IRDM direct", "float, T = 500", full_model.bytes(), 0,
                                     run_irdm(s, full_model, direct, true, bound)));
        }
        for (const double theta : {0.80, 0.85, 0.90, 0.95})
          {
            CompressionOptions co;
            co.theta = theta;
            co.log   = [&](const std::string &l) { log << "  theta " << theta << ": " << l << "\n"; };
            const RepresentativeModel c = compress(full_model, co);
            cells[0].push_back(std::to_string(c.n_representative()));
            cells[1].push_back(std::to_string(c.n_substituted));
            cells[2].push_back(fmt(100.0 * c.n_representative() / waveforms, "%.1f%%"));
            cells[3].push_back(fmt(c.representative_bytes() / 1e9, "%.3f"));
            cells[4].push_back(fmt(c.bytes() / 1e9, "%.3f") + " (" + fmt(100 * c.bytes() / h_bytes, "%.1f%%") + ")");
            cells[5].push_back(fmt(c.compression_seconds, "%.1f"));
            cells[6].push_back(fmt(c.mean_fit, "%.3f") + " / " + fmt(c.mean_delay, "%.1f"));
            RepresentativeInteraction irdm(c);
            full_rows.push_back(row_of("representatives", "theta " + fmt(theta, "%.2f"), c.bytes(),
                                       c.compression_seconds, run_irdm(s, c, irdm, true, bound)));
            full_rows.back().rep_percent = 100.0 * c.n_representative() / waveforms;
          }
        for (const unsigned M : {50u, 100u, 200u})
          {
            const ModalModel mm = make_modal_model(full_model, {M});
            ModalInteraction irdm(mm);
            full_rows.push_back(row_of("modal", "M " + std::to_string(M), mm.bytes(),
                                       mm.build_seconds, run_irdm(s, mm, irdm, true, bound)));
          }
        const char *labels[7] = {"number of representative data", "number of non-representative data",
                                 "compression ratio (representatives / waveforms)",
                                 "data size of the representatives (GB)",
                                 "data size with the delay/amplitude tables (GB, % of float H)",
                                 "compression time (s, 2 threads)", "mean fit correlation / mean delay (steps)"};
        const std::string original[7] = {"-", "-", "100.0%", fmt(h_bytes / 1e9, "%.3f"), fmt(h_bytes / 1e9, "%.3f"),
                                         "-", "-"};
        for (int i = 0; i < 7; ++i)
          {
            table1 << "| " << labels[i];
            for (const auto &c : cells[i])
              table1 << " | " << c;
            table1 << " | " << original[i] << " |\n";
          }
        full << "### Seed Table 1 for our cat (representative waveforms, plain substitution)\n\n"
             << full_model.n_inputs << " x " << full_model.n_outputs << " = " << fmt(waveforms, "%.0f")
             << " waveforms of T = " << full_model.length << " samples (seed: 1077 x 1077 of 500). "
             << "Per-input pools, the 8 nearest representatives searched, delays 0..64 steps.\n\n"
             << table1.str() << "\n"
             << "Seed 000 (its cat, 359 surface nodes): 12974 / 26582 / 59109 / 158231 "
                "representatives = 1.1 / 2.3 / 5.1 / 13.6 %, 0.02 / 0.05 / 0.10 / 0.29 GB of 2.14 GB.\n\n"
             << "### The full model in closed loop (scene `" << s.name << "`, "
             << (o.full_model_stride > 1 ? "the sampled inputs" : "every surface vertex an input")
             << ")\n\n"
             << "Errors against the FEM include the truncation at T = 500 (section (b) of the scene "
                "report); the times are those of the full cat surface update.\n\n"
             << compression_section(full_rows, full_model.n_outputs) << "\n";
        write_compression_csv((fs::path(o.report_dir) / "full_model_compression.csv").string(), full_rows);
      }

    std::ostringstream f;
    f << "# IRDM point interaction against the reference FEM\n\n"
      << report_stamp() << "\n\n"
      << "Generated by `irdm validate`. One restricted model per scene (inputs: the scene's "
         "touched region; outputs: every free surface vertex; T >= the scene's steps, double). "
         "Exactness is the untruncated double model against the FEM at the same step; the "
         "float column is the same model rounded to float.\n\n"
      << summary.str() << "\n" << compression_summary(comp_rows) << full.str();
    write_text_file((fs::path(o.report_dir) / "validation.md").string(), f.str());
    log << "report: " << (fs::path(o.report_dir) / "validation.md").string() << "\n";
    return all_exact;
  }
} // namespace irdm::validation
