// IRDM point-interaction validation against the reference FEM. Data flow: scene -> FEM run
// (ground truth) and precompute -> model file -> IRDM runtime -> comparison -> report.
#include <irdm/model.h>
#include <irdm/point_interaction.h>
#include <irdm_common/csv.h>
#include <irdm_common/error.h>
#include <irdm_common/geometry.h>
#include <reference_fem/elastodynamics.h>
#include <reference_fem/impulse_response.h>
#include <validation/point_validation.h>

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
    using Clock = std::chrono::steady_clock;
    using Vec3  = std::array<double, 3>;
    double
    since(const Clock::time_point t0)
    {
      return std::chrono::duration<double>(Clock::now() - t0).count();
    }
    double
    norm(const Vec3 &a)
    {
      return std::sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]);
    }

    // Samples k = 1..N of one run: probe forces and the displacement of the model's outputs.
    struct Series
    {
      std::vector<std::vector<Vec3>>   force;   // [probe][k-1]
      std::vector<std::vector<double>> surface; // [k-1][output DoF]
      double force_loop_seconds = 0, surface_seconds = 0, step_seconds = 0;
    };

    struct Errors
    {
      double force_rel_l2 = 0, force_max = 0, disp_rms = 0, disp_max = 0;
      std::vector<double> force_t, disp_rms_t; // per sample, relative to the peaks
    };

    Errors
    compare(const Series &test, const Series &truth)
    {
      Errors e;
      double num = 0, den = 0, fpeak = 0, dmax = 0;
      const size_t N = truth.surface.size();
      for (size_t p = 0; p < truth.force.size(); ++p)
        for (size_t k = 0; k < N; ++k)
          fpeak = std::max(fpeak, norm(truth.force[p][k]));
      double upeak = 0;
      for (const auto &u : truth.surface)
        for (size_t j = 0; j + 2 < u.size(); j += 3)
          upeak = std::max(upeak, norm({u[j], u[j + 1], u[j + 2]}));
      e.force_t.assign(N, 0);
      e.disp_rms_t.assign(N, 0);
      double sum2 = 0;
      size_t count = 0;
      for (size_t k = 0; k < N; ++k)
        {
          for (size_t p = 0; p < truth.force.size(); ++p)
            {
              Vec3 d;
              for (int c = 0; c < 3; ++c)
                d[c] = test.force[p][k][c] - truth.force[p][k][c];
              num += d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
              den += std::pow(norm(truth.force[p][k]), 2);
              e.force_max = std::max(e.force_max, norm(d));
              e.force_t[k] = std::max(e.force_t[k], norm(d) / fpeak);
            }
          double s2 = 0;
          const auto &a = test.surface[k], &b = truth.surface[k];
          for (size_t j = 0; j + 2 < b.size(); j += 3)
            {
              const double d = norm({a[j] - b[j], a[j + 1] - b[j + 1], a[j + 2] - b[j + 2]});
              s2 += d * d;
              dmax = std::max(dmax, d);
            }
          sum2 += s2;
          count += b.size() / 3;
          e.disp_rms_t[k] = std::sqrt(s2 / (b.size() / 3)) / upeak;
        }
      e.force_rel_l2 = std::sqrt(num / den);
      e.force_max /= fpeak;
      e.disp_rms = std::sqrt(sum2 / count) / upeak;
      e.disp_max = dmax / upeak;
      return e;
    }

    // FEM run at tau / refine; keeps the samples at t = k tau, k = 1..N, on the model outputs.
    // Forces are averaged over the refine sub-steps of each tau: the impulse delivered during
    // the step divided by tau, the quantity the IRDM force sample stands for.
    Series
    run_fem(fem::Scene scene, const ImpulseResponseModel &model, const unsigned refine,
            const unsigned N)
    {
      scene.time_step /= refine;
      scene.outputs           = {};
      scene.outputs.surface   = true;
      scene.outputs.directory = "";
      fem::ElasticDynamics fem(scene);
      const auto           r = fem.run();
      std::map<long long, unsigned> index;
      for (unsigned i = 0; i < r.surface.node_tags.size(); ++i)
        index[r.surface.node_tags[i]] = i;
      Series s;
      s.step_seconds = r.stepping_seconds / r.n_steps;
      for (const auto &p : scene.probes)
        {
          s.force.emplace_back();
          for (unsigned k = 1; k <= N; ++k)
            {
              Vec3 mean = {0, 0, 0};
              for (unsigned i = (k - 1) * refine + 1; i <= k * refine; ++i)
                for (int c = 0; c < 3; ++c)
                  mean[c] += r.probe_force.at(p.name)[i][c] / refine;
              s.force.back().push_back(mean);
            }
        }
      for (unsigned k = 1; k <= N; ++k)
        {
          std::vector<double> u(model.n_outputs);
          for (unsigned v = 0; v < model.output_node_tags.size(); ++v)
            {
              const unsigned i = index.at(model.output_node_tags[v]);
              for (int d = 0; d < 3; ++d)
                u[3 * v + d] = r.surface_displacement[k * refine][3 * i + d];
            }
          s.surface.push_back(std::move(u));
        }
      return s;
    }

    // IRDM run of the scene's probes: step n is FEM time (n + 1) tau.
    Series
    run_irdm(const fem::Scene &scene, const ImpulseResponseModel &model, const unsigned taps,
             const bool with_surface)
    {
      const unsigned N = scene.n_steps();
      const int      P = static_cast<int>(scene.probes.size());
      // Candidate triangles of each probe's surface (those of the model are off the fixed
      // surfaces, as the FEM's).
      std::vector<std::vector<unsigned>> candidates(P);
      std::vector<std::vector<std::array<unsigned, 3>>> tris(P);
      for (int p = 0; p < P; ++p)
        {
          const auto it = std::find(model.surface_names.begin(), model.surface_names.end(),
                                    scene.probes[p].surface);
          if (it == model.surface_names.end())
            throw InputError("probe '" + scene.probes[p].name + "': the model has no surface '" +
                             scene.probes[p].surface + "'");
          const int sid = static_cast<int>(it - model.surface_names.begin());
          for (unsigned t = 0; t < model.triangles.size(); ++t)
            if (model.triangle_surface[t] == sid)
              {
                candidates[p].push_back(t);
                tris[p].push_back(model.triangles[t]);
              }
        }
      PointInteraction    irdm(model, taps);
      Series              s;
      std::vector<double> u(model.n_outputs);
      s.force.assign(P, {});
      std::array<ProbeTarget, contact::max_probes> targets;
      for (unsigned n = 0; n < N; ++n)
        {
          const double t = (n + 1) * scene.time_step;
          for (int p = 0; p < P; ++p)
            {
              const auto &pr = scene.probes[p];
              const auto  sp = geometry::closest_point(model.output_coordinates, tris[p], pr.path.at(t));
              targets[p].triangle = static_cast<int>(candidates[p][sp.triangle]);
              targets[p].weights  = sp.weights;
              for (int d = 0; d < 3; ++d)
                targets[p].displacement[d] = pr.depth.at(t) * pr.direction[d];
              targets[p].direction  = pr.direction;
              targets[p].unilateral = pr.unilateral;
              targets[p].present    = t <= pr.until;
            }
          const auto t0 = Clock::now();
          if (!irdm.step(targets.data(), P))
            throw InputError("scene '" + scene.name + "': at t = " + std::to_string(t) +
                             " s a probe touches a triangle whose vertices are not all model "
                             "inputs; widen the scene's model.inputs region");
          s.force_loop_seconds += since(t0);
          for (int p = 0; p < P; ++p)
            s.force[p].push_back(irdm.force(p));
          if (with_surface)
            {
              const auto t1 = Clock::now();
              irdm.surface_displacement(u.data());
              s.surface_seconds += since(t1);
              s.surface.push_back(u);
            }
        }
      s.force_loop_seconds /= N;
      s.surface_seconds /= N;
      return s;
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

    std::string
    fmt(const double x, const char *f = "%.3g")
    {
      char b[64];
      std::snprintf(b, sizeof b, f, x);
      return b;
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
        po.length  = std::max(scene.model.length, N);
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
        const Series irdm_full  = run_irdm(scene, model, 0, true);
        const Errors exact      = compare(irdm_full, fem_run);
        const auto   model_f    = model.as_float();
        const Errors exact_f    = compare(run_irdm(scene, model_f, 0, true), fem_run);
        const Series irdm_force = run_irdm(scene, model, 0, false); // force loop alone
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
          trunc.push_back(compare(run_irdm(scene, model, T, true), fem_run));

        const fem::Scene phase      = contact_phase(scene);
        const unsigned   Nc         = phase.n_steps();
        const Series     phase_fem  = run_fem(phase, model, 1, Nc);
        const Series     phase_fine = run_fem(phase, model, 10, Nc);
        const Series     phase_irdm = run_irdm(phase, model, 0, true);
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

        // 4. Report files.
        const fs::path dir = fs::path(o.report_dir) / scene.name;
        fs::create_directories(dir);
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
           << "## (d) Cost per step, measured in the same run (wall clock, one core)\n\n"
           << "| IRDM force loop | IRDM full surface update (" << model.n_outputs / 3
           << " vertices) | FEM step (P" << scene.fe_degree << ", MUMPS) |\n|---|---|---|\n"
           << "| " << fmt(1e6 * irdm_force.force_loop_seconds) << " us | "
           << fmt(1e6 * irdm_full.surface_seconds) << " us | " << fmt(1e3 * fem_run.step_seconds)
           << " ms |\n\n"
           << "The IRDM costs grow with the number of inputs that carry force inside the window "
              "T (direct convolution, no compression). CSV: `series.csv`, `truncation.csv`.\n";
        {
          std::ofstream f(dir / "report.md");
          f << md.str();
        }
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
        s.model      = {};
        fem::PrecomputeOptions po;
        po.output  = (fs::path(o.model_dir) / "full.h5").string();
        po.restart = true;
        po.log     = [&](const std::string &l) {
          if (l.rfind("chunk", 0) != 0)
            log << "  full model: " << l << "\n";
        };
        const auto r = fem::precompute_impulse_responses(s, po);
        fs::remove(po.output);
        full << "## Full model of the cat\n\nEvery free surface vertex DoF in and out, T = "
             << r.length << ", float: " << r.n_inputs << " x " << r.n_outputs << " x " << r.length
             << " = " << fmt(r.bytes / 1e6) << " MB, precomputed in " << fmt(r.seconds_total)
             << " s (FEM " << fmt(r.seconds_fem) << " s, all " << r.n_free << " modes "
             << fmt(r.seconds_eigen) << " s, responses (GEMM) " << fmt(r.seconds_responses)
             << " s, HDF5 write " << fmt(r.seconds_write) << " s), " << r.ranks
             << " rank(s). Energy left after T: mean " << fmt(r.energy_left_mean) << ", max "
             << fmt(r.energy_left_max) << "; driving-point static compliance beyond T: mean "
             << fmt(r.static_left_mean) << ", max " << fmt(r.static_left_max) << ".\n\n";
      }
    std::ofstream f(fs::path(o.report_dir) / "validation.md");
    f << "# IRDM point interaction against the reference FEM\n\n"
      << "Generated by `irdm validate`. One restricted model per scene (inputs: the scene's "
         "touched region; outputs: every free surface vertex; T >= the scene's steps, double). "
         "Exactness is the untruncated double model against the FEM at the same step; the "
         "float column is the same model rounded to float.\n\n"
      << summary.str() << "\n" << full.str();
    log << "report: " << (fs::path(o.report_dir) / "validation.md").string() << "\n";
    return all_exact;
  }
} // namespace irdm::validation
