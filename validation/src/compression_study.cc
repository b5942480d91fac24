// Issue 4's comparison on one scene: representative waveforms (plain and interpolated) at each
// theta, the modal realization at several M, the realization identified from H alone (ERA) and
// the modal realization's balanced truncation at several orders, and the uncompressed model,
// each in closed loop.
#include <irdm_common/format.h>
#include <irdm_common/error.h>
#include <irdm_common/files.h>
#include <irdm/modal_model.h>
#include <irdm/representative_interaction.h>
#include <irdm/representative_model.h>
#include <irdm/state_space_interaction.h>
#include <irdm/state_space_model.h>

#include <cstdio>
#include <fstream>
#include <memory>
#include <sstream>

#include "compression_study.h"

namespace irdm::validation
{
  namespace
  {
    template <class Interaction, class Model>
    CompressionRow
    measure(const fem::Scene &scene, const Model &m, const Series &fem_run, const double bound)
    {
      Interaction irdm(m);
      return measured_row(run_irdm(scene, m, irdm, true, bound), fem_run);
    }

    void
    log_row(std::ostream &log, const CompressionRow &r)
    {
      log << "  " << r.method << " " << r.setting << ": " << fmt(r.percent) << " % size, disp. RMS "
          << fmt(r.errors.disp_rms) << ", force L2 " << fmt(r.errors.force_rel_l2)
          << (r.stable ? "" : ", UNSTABLE") << "\n";
    }
  } // namespace

  namespace
  {
    /// A state-space compressor's rows: prepared once for the largest order it can hold
    /// (prepare(order) throws InputError beyond it), realized at each order (realize(order)
    /// throws where the rank is below it: no row).
    template <class Prepare, class Realize>
    std::vector<CompressionRow>
    state_space_rows(const char *method, const fem::Scene &scene, const ImpulseResponseModel &model,
                     const Series &fem_run, const std::vector<unsigned> &orders, std::ostream &log,
                     Prepare &&prepare, Realize &&realize)
    {
      const double bound   = 10 * peak_force(fem_run);
      const double h_float = 4.0 * model.n_inputs * model.n_outputs * model.length;
      std::vector<CompressionRow> rows;
      unsigned                    prepared = 0;
      for (auto largest = orders.rbegin(); largest != orders.rend() && !prepared; ++largest)
        try
          {
            prepare(*largest);
            prepared = *largest;
          }
        catch (const InputError &e)
          {
            log << "  " << method << " r " << *largest << ": not made (" << e.what() << ")\n";
          }
      for (const unsigned order : orders)
        {
          if (order > prepared)
            continue;
          StateSpaceModel ss;
          try
            {
              ss = realize(order);
            }
          catch (const InputError &e)
            {
              log << "  " << method << " r " << order << ": not made (" << e.what() << ")\n";
              continue;
            }
          CompressionRow r = measure<StateSpaceInteraction>(scene, ss, fem_run, bound);
          r.method        = method;
          r.setting       = "r " + std::to_string(order);
          r.value         = order;
          r.bytes         = ss.bytes();
          r.percent       = 100 * r.bytes / h_float;
          r.build_seconds = ss.identification_seconds;
          log_row(log, r);
          rows.push_back(r);
        }
      return rows;
    }
  } // namespace

  std::vector<CompressionRow>
  era_rows(const fem::Scene &scene, const ImpulseResponseModel &model, const Series &fem_run,
           const std::vector<unsigned> &orders, std::ostream &log, const EraOptions &base)
  {
    std::shared_ptr<const EraHankel> hankel;
    return state_space_rows(
      "era", scene, model, fem_run, orders, log,
      [&](const unsigned order) {
        EraOptions o = base;
        o.order      = order;
        hankel       = prepare_era(model, o);
      },
      [&](const unsigned order) { return realize_era(model, *hankel, order); });
  }

  std::vector<CompressionRow>
  balanced_rows(const fem::Scene &scene, const ImpulseResponseModel &model, const Series &fem_run,
                const std::vector<unsigned> &orders, std::ostream &log)
  {
    std::shared_ptr<const BalancedGramians> gramians;
    return state_space_rows(
      "balanced", scene, model, fem_run, orders, log,
      [&](const unsigned order) {
        BalancedOptions o;
        o.order  = order;
        gramians = prepare_balanced(model, o);
      },
      [&](const unsigned order) { return realize_balanced(model, *gramians, order); });
  }

  CompressionRow
  measured_row(const Series &run, const Series &fem_run)
  {
    CompressionRow r;
    r.errors        = compare(run, fem_run);
    r.force_loop_us = 1e6 * run.force_loop_seconds;
    r.surface_us    = 1e6 * run.surface_seconds;
    r.diverged_at   = run.diverged_at;
    r.stable        = run.diverged_at < 0;
    return r;
  }

  std::vector<CompressionRow>
  compression_study(const fem::Scene &scene, const ImpulseResponseModel &model,
                    const Series &fem_run, std::ostream &log)
  {
    // A run whose force passes 10 x the FEM's peak is stopped and reported unstable.
    const double bound   = 10 * peak_force(fem_run);
    const double h_float = 4.0 * model.n_inputs * model.n_outputs * model.length;
    std::vector<CompressionRow> rows;

    CompressionRow fem;
    fem.method        = "FEM";
    fem.setting       = "P" + std::to_string(scene.fe_degree) + " (ground truth)";
    fem.force_loop_us = fem.surface_us = 1e6 * fem_run.step_seconds;
    rows.push_back(fem);

    for (const bool as_float : {false, true})
      {
        const ImpulseResponseModel f = as_float ? model.as_float() : ImpulseResponseModel();
        const ImpulseResponseModel &m = as_float ? f : model;
        CompressionRow r = measure<PointInteraction>(scene, m, fem_run, bound);
        r.method  = "IRDM direct";
        r.setting = as_float ? "float" : "double";
        r.bytes   = m.bytes();
        r.percent = 100 * r.bytes / h_float;
        rows.push_back(r);
      }
    for (const unsigned blend : {1u, 3u})
      for (const double theta : {0.80, 0.85, 0.90, 0.95, 0.99, 0.999})
        {
          CompressionOptions o;
          o.theta = theta;
          o.blend = blend;
          const RepresentativeModel c = compress(model, o);
          CompressionRow r = measure<RepresentativeInteraction>(scene, c, fem_run, bound);
          r.method        = blend == 1 ? "representatives" : "interpolated";
          r.setting       = "theta " + fmt(theta, "%.3g") + (blend > 1 ? ", blend 3" : "");
          r.value         = theta;
          r.bytes         = c.bytes();
          r.percent       = 100 * r.bytes / h_float;
          r.rep_percent   = 100.0 * c.n_representative() / (double(model.n_inputs) * model.n_outputs);
          r.build_seconds = c.compression_seconds;
          log_row(log, r);
          rows.push_back(r);
        }
    for (const unsigned M : {25u, 50u, 100u, 200u, 400u, 800u})
      {
        if (M > model.modes.n_modes)
          break;
        const ModalModel mm = make_modal_model(model, {M});
        CompressionRow   r  = measure<ModalInteraction>(scene, mm, fem_run, bound);
        r.method        = "modal";
        r.setting       = "M " + std::to_string(M) + " (to " + fmt(mm.highest_frequency_hz) + " Hz)";
        r.value         = M;
        r.bytes         = mm.bytes();
        r.percent       = 100 * r.bytes / h_float;
        r.build_seconds = mm.build_seconds;
        log_row(log, r);
        rows.push_back(r);
      }
    for (auto &r : era_rows(scene, model, fem_run, {300, 600, 1000}, log))
      rows.push_back(r);
    if (model.modes.n_modes > 0 && !model.free_body)
      for (auto &r : balanced_rows(scene, model, fem_run, {100, 300, 600, 1000}, log))
        rows.push_back(r);
    return rows;
  }

  void
  write_compression_csv(const std::string &path, const std::vector<CompressionRow> &rows)
  {
    std::ostringstream f;
    f.precision(10);
    f << "method,setting,value,bytes,percent_of_float_H,representatives_percent,build_s,"
         "force_rel_l2,force_max_rel,disp_rms_rel,disp_max_rel,force_loop_us,surface_update_us,"
         "stable,diverged_at_s\n";
    for (const auto &r : rows)
      f << r.method << ",\"" << r.setting << "\"," << r.value << "," << r.bytes << "," << r.percent
        << "," << r.rep_percent << "," << r.build_seconds << "," << r.errors.force_rel_l2 << ","
        << r.errors.force_max << "," << r.errors.disp_rms << "," << r.errors.disp_max << ","
        << r.force_loop_us << "," << r.surface_us << "," << (r.stable ? 1 : 0) << ","
        << r.diverged_at << "\n";
    write_text_file(path, f.str());
  }

  std::string
  compression_section(const std::vector<CompressionRow> &rows, const unsigned n_outputs)
  {
    std::ostringstream md;
    md << "| method | setting | memory MB | % of float H | representatives % | build s | force "
          "rel. L2 | disp. RMS | disp. max | force loop us/step | full update ("
       << n_outputs / 3 << " vertices) us/step | closed loop |\n"
       << "|---|---|---|---|---|---|---|---|---|---|---|---|\n";
    for (const auto &r : rows)
      {
        const bool fem = r.method == "FEM";
        md << "| " << r.method << " | " << r.setting << " | " << (fem ? "-" : fmt(r.bytes / 1e6))
           << " | " << (fem ? "-" : fmt(r.percent)) << " | "
           << (r.rep_percent >= 0 ? fmt(r.rep_percent) : "-") << " | "
           << (r.build_seconds > 0 ? fmt(r.build_seconds) : "-") << " | "
           << (fem ? "0 (reference)" : fmt(r.errors.force_rel_l2)) << " | "
           << (fem ? "0" : fmt(r.errors.disp_rms)) << " | " << (fem ? "0" : fmt(r.errors.disp_max))
           << " | " << fmt(r.force_loop_us) << " | "
           << (fem ? "(in the step)" : fmt(r.surface_us)) << " | "
           << (r.stable ? "stable"
                        : "**UNSTABLE** (force > 10x FEM peak at t = " + fmt(r.diverged_at) + " s)")
           << " |\n";
      }
    return md.str();
  }
} // namespace irdm::validation
