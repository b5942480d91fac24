// The full cat model of the point validation (point_runs.h): the seed's Table 1 by
// representative waveforms, and every compressor in closed loop on the first scene
// (representatives plain and interpolated, modal, ERA, balanced truncation).
#include "point_runs.h"

#include <irdm/modal_model.h>
#include <irdm/point_interaction.h>
#include <irdm/representative_interaction.h>
#include <irdm/representative_model.h>
#include <irdm_common/format.h>

namespace fs = std::filesystem;

namespace irdm::validation::points
{
  FullModelRun
  run_full_model(const std::string &first_scene, const PointValidationOptions &o, std::ostream &log)
  {
    // Every free surface DoF in and out (or every stride-th input vertex and the scene's
    // inputs, which its probes must touch), T = 500, float.
    fem::Scene             s = fem::read_scene(first_scene);
    fem::PrecomputeOptions po;
    po.input_stride  = o.full_model_stride;
    po.inputs_always = s.model.inputs;
    s.model          = {};
    po.output        = (fs::path(o.model_dir) / "full.h5").string();
    refuse_existing_model(po.output);
    po.restart = true;
    po.log     = [&](const std::string &l) {
      if (l.rfind("chunk", 0) != 0)
        log << "  full model: " << l << "\n";
    };
    FullModelRun run;
    run.scene  = s.name;
    run.stride = o.full_model_stride;
    run.pre    = fem::precompute_impulse_responses(s, po);

    // The scene's probes driving the full model (T = 500, so the errors against the FEM
    // include the truncation of the scene report's section (b)).
    log << "  full model: loading for the compression table\n";
    const ImpulseResponseModel full_model = load_model(po.output, s.time_step);
    fs::remove(po.output);
    run.n_inputs  = full_model.n_inputs;
    run.n_outputs = full_model.n_outputs;
    run.length    = full_model.length;
    run.waveforms = double(full_model.n_inputs) * full_model.n_outputs;
    run.h_bytes   = 4.0 * run.waveforms * full_model.length;
    const Series fem_full = run_fem(s, full_model, 1, s.n_steps());
    const double bound    = 10 * peak_force(fem_full);
    const auto   row_of   = [&](const std::string &method, const std::string &setting,
                            const double bytes, const double build_seconds, const Series &series) {
      CompressionRow row = measured_row(series, fem_full);
      row.method         = method;
      row.setting        = setting;
      row.bytes          = bytes;
      row.percent        = 100 * bytes / run.h_bytes;
      row.build_seconds  = build_seconds;
      return row;
    };
    {
      PointInteraction direct(full_model);
      run.rows.push_back(row_of("IRDM direct", "float, T = 500", full_model.bytes(), 0,
                                run_irdm(s, full_model, direct, true, bound)));
    }
    // Representatives plain (blend 1, also the seed's Table 1: one row per quantity, one
    // column per theta), then interpolated (each substituted waveform a blend of three).
    run.table1.assign(7, {});
    for (const unsigned blend : {1u, 3u})
      for (const double theta : {0.80, 0.85, 0.90, 0.95})
        {
          CompressionOptions co;
          co.theta = theta;
          co.blend = blend;
          const std::string setting =
            "theta " + fmt(theta, "%.2f") + (blend > 1 ? ", blend " + std::to_string(blend) : "");
          co.log = [&](const std::string &l) { log << "  " << setting << ": " << l << "\n"; };
          const RepresentativeModel c = compress(full_model, co);
          if (blend == 1)
            {
              auto &t = run.table1;
              t[0].push_back(std::to_string(c.n_representative()));
              t[1].push_back(std::to_string(c.n_substituted));
              t[2].push_back(fmt(100.0 * c.n_representative() / run.waveforms, "%.1f%%"));
              t[3].push_back(fmt(c.representative_bytes() / 1e9, "%.3f"));
              t[4].push_back(fmt(c.bytes() / 1e9, "%.3f") + " (" + fmt(100 * c.bytes() / run.h_bytes, "%.1f%%") + ")");
              t[5].push_back(fmt(c.compression_seconds, "%.1f"));
              t[6].push_back(fmt(c.mean_fit, "%.3f") + " / " + fmt(c.mean_delay, "%.1f"));
            }
          RepresentativeInteraction irdm(c);
          run.rows.push_back(row_of(blend > 1 ? "interpolated" : "representatives", setting, c.bytes(),
                                    c.compression_seconds, run_irdm(s, c, irdm, true, bound)));
          run.rows.back().rep_percent = 100.0 * c.n_representative() / run.waveforms;
        }
    for (const unsigned M : {50u, 100u, 200u})
      {
        const ModalModel mm = make_modal_model(full_model, {M});
        ModalInteraction irdm(mm);
        run.rows.push_back(row_of("modal", "M " + std::to_string(M), mm.bytes(), mm.build_seconds,
                                  run_irdm(s, mm, irdm, true, bound)));
      }
    for (auto &r : era_rows(s, full_model, fem_full, {300, 600, 1000}, log))
      run.rows.push_back(r);
    // ERA's peer where the modes are known: balanced truncation of the modal realization.
    if (full_model.modes.n_modes > 0 && !full_model.free_body)
      for (auto &r : balanced_rows(s, full_model, fem_full, {300, 600, 1000}, log))
        run.rows.push_back(r);
    return run;
  }
} // namespace irdm::validation::points
