// The point validation's runner for one scene (point_runs.h).
#include "point_runs.h"

#include <irdm/model.h>
#include <irdm/point_interaction.h>
#include <irdm_common/error.h>
#include <irdm_common/format.h>
#include <irdm_common/h5.h>
#include <reference_fem/elastodynamics.h>

#include <algorithm>
#include <cmath>

namespace fs = std::filesystem;

namespace irdm::validation::points
{
  namespace
  {
    /// The uncompressed model, all taps or the first `taps`.
    Series
    run_direct(const fem::Scene &scene, const ImpulseResponseModel &model, const unsigned taps,
               const bool with_surface)
    {
      PointInteraction irdm(model, taps);
      return run_irdm(scene, model, irdm, with_surface);
    }

    /// The time-step study's scene: the contact phase only (until the first probe's depth
    /// first returns to 0 after pushing), with bilateral probes. A unilateral vertex contact on
    /// an implicit integrator switches on and off between steps (chatter), and at tau/10 that
    /// switching does not converge (the report shows it), so it cannot serve as ground truth.
    fem::Scene
    contact_phase(const fem::Scene &scene)
    {
      fem::Scene c   = scene;
      double     end = scene.duration;
      for (auto &p : c.probes)
        {
          p.unilateral  = false;
          end           = std::min(end, p.until);
          const auto &t = p.depth.times, &v = p.depth.values;
          bool        pushed = false;
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

    /// The peak probe force over the first N samples, and whether every sample is finite.
    std::pair<double, bool>
    peak_and_finite(const Series &s, const size_t n_probes, const unsigned N)
    {
      double peak   = 0;
      bool   finite = true;
      for (size_t p = 0; p < n_probes; ++p)
        for (unsigned k = 0; k < N; ++k)
          {
            peak   = std::max(peak, norm(s.force[p][k]));
            finite = finite && std::isfinite(norm(s.force[p][k]));
          }
      return {peak, finite};
    }

    CouplingSweep
    run_coupling_sweep(const fem::Scene &scene, const ImpulseResponseModel &model,
                       const double fem_peak, const std::string &fine_model_file, std::ostream &log)
    {
      CouplingSweep sweep;
      sweep.fem_peak = fem_peak;
      for (const auto &p : scene.probes)
        sweep.k0 = std::max(sweep.k0, p.coupling_stiffness),
        sweep.b0 = std::max(sweep.b0, p.coupling_damping);
      const unsigned N   = scene.n_steps();
      const auto     add = [&](const double k, const double b) {
        fem::Scene c = scene;
        for (auto &p : c.probes)
          p.coupling_stiffness = k, p.coupling_damping = b;
        PointInteraction irdm(model);
        sweep.runs.push_back({k, b, scene.time_step, "irdm", run_irdm(c, model, irdm, false, 100 * fem_peak)});
        sweep.runs.push_back({k, b, scene.time_step / 10, "fem", run_fem(c, model, 10, N)});
      };
      log << "  coupling sweep" << std::flush;
      add(0, 0);
      for (const double fk : {0.1, 0.3, 1.0, 3.0, 10.0, 100.0})
        for (const double fb : {0.0, 1.0, 10.0})
          {
            add(fk * sweep.k0, fb * sweep.b0);
            log << "." << std::flush;
          }
      log << "\n";

      // IRDM at tau/10 too, from a model precomputed at tau/10 whose outputs are its inputs
      // (the probe's region: the force loop needs no more), against the FEM at tau/10 with
      // the same coupling: the scene's own coupling and the rigid probe.
      fem::Scene fine = scene;
      fine.time_step /= 10;
      fine.model.outputs = fine.model.inputs;
      refuse_existing_model(fine_model_file);
      fem::PrecomputeOptions po;
      po.output = fine_model_file;
      po.length = fine.n_steps();
      fem::precompute_impulse_responses(fine, po);
      const ImpulseResponseModel fine_model = load_model(fine_model_file, fine.time_step);
      sweep.fine_tau      = fine.time_step;
      sweep.fine_vertices = fine_model.n_inputs / 3;
      sweep.fine_length   = fine_model.length;
      for (const bool rigid : {false, true})
        {
          fem::Scene c = fine;
          if (rigid)
            for (auto &p : c.probes)
              p.coupling_stiffness = p.coupling_damping = 0;
          PointInteraction irdm(fine_model);
          sweep.fine.push_back({sweep.k0, sweep.b0, c.time_step, "irdm",
                                run_irdm(c, fine_model, irdm, false, 100 * fem_peak)});
          sweep.fine.push_back({sweep.k0, sweep.b0, c.time_step, "fem",
                                run_fem(c, fine_model, 1, c.n_steps())});
        }
      fs::remove(fine_model_file);
      return sweep;
    }
  } // namespace

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

  SceneRun
  run_scene(const std::string &file, const PointValidationOptions &o, std::ostream &log)
  {
    SceneRun r;
    r.file                  = file;
    r.scene                 = fem::read_scene(file);
    const fem::Scene &scene = r.scene;
    r.N                     = scene.n_steps();
    const unsigned N        = r.N;
    log << "== " << scene.name << ": " << N << " steps of " << scene.time_step << " s\n";

    // The model, restricted to the scene's touched region; T >= N so nothing truncates.
    fem::PrecomputeOptions po;
    po.output = (fs::path(o.model_dir) / (scene.name + ".h5")).string();
    refuse_existing_model(po.output);
    po.length  = std::max(o.length.value_or(scene.model.length), N);
    po.restart = true;
    r.pre      = fem::precompute_impulse_responses(scene, po);
    const ImpulseResponseModel model = load_model(po.output, scene.time_step);
    r.n_inputs = model.n_inputs, r.n_outputs = model.n_outputs, r.length = model.length;
    log << "  model " << model.n_outputs << " x " << model.n_inputs << " x " << model.length
        << " in " << fmt(r.pre.seconds_total) << " s, " << fmt(r.pre.bytes / 1e6) << " MB\n";

    // The truth, and the FEM at tau / 10 with the scene's unilateral contact (does it stay
    // bounded?).
    r.fem_run             = run_fem(scene, model, 1, N);
    r.fem_fine_unilateral = run_fem(scene, model, 10, N);
    std::tie(r.peak_fine, r.fine_finite) = peak_and_finite(r.fem_fine_unilateral, scene.probes.size(), N);
    log << "  FEM " << fmt(1e3 * r.fem_run.step_seconds) << " ms/step\n";

    // (a) Exactness: all taps, double and float; the force loop alone for its cost. The float
    // copy lives only for this run: holding it would raise the peak by half the model.
    r.peak_coarse = peak_and_finite(r.fem_run, scene.probes.size(), N).first;
    r.irdm_full   = run_direct(scene, model, 0, true);
    r.exact       = compare(r.irdm_full, r.fem_run);
    r.exact_float = compare(run_direct(scene, model.as_float(), 0, true), r.fem_run);
    r.irdm_force  = run_direct(scene, model, 0, false);
    r.pass        = r.exact.force_rel_l2 < 1e-9 && r.exact.disp_max < 1e-9;
    log << "  exactness: force rel. L2 " << fmt(r.exact.force_rel_l2) << ", disp. max "
        << fmt(r.exact.disp_max) << (r.pass ? " (pass)" : " (FAIL: above 1e-9)") << "\n";

    // (b) Truncation.
    for (const unsigned T : {50u, 100u, 200u, 300u, 500u, 750u, 1000u})
      if (T <= model.length)
        r.taps.push_back(T);
    for (const unsigned T : r.taps)
      r.truncated.push_back(compare(run_direct(scene, model, T, true), r.fem_run));

    // (c) Time step.
    r.phase                 = contact_phase(scene);
    const unsigned Nc       = r.phase.n_steps();
    const Series   phase_fem = run_fem(r.phase, model, 1, Nc);
    r.phase_fine            = run_fem(r.phase, model, 10, Nc);
    r.phase_irdm            = run_direct(r.phase, model, 0, true);
    r.step_irdm             = compare(r.phase_irdm, r.phase_fine);
    r.step_fem              = compare(phase_fem, r.phase_fine);

    // (e) Compression: every compressor in closed loop against the same FEM run.
    r.compression = compression_study(scene, model, r.fem_run, log);

    // (f) Virtual coupling, on scenes with a coupled probe.
    bool coupled = false;
    for (const auto &p : scene.probes)
      coupled = coupled || p.coupling_stiffness > 0 || p.coupling_damping > 0;
    if (coupled)
      r.coupling = run_coupling_sweep(scene, model, r.peak_coarse,
                                      (fs::path(o.model_dir) / (scene.name + "_tau10.h5")).string(), log);
    fs::remove(po.output); // models are large; the report keeps their figures
    return r;
  }
} // namespace irdm::validation::points
