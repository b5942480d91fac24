// The point validation's reports (point_runs.h): each scene's CSV files and report.md, and
// validation.md over every scene and the full model.
#include "point_runs.h"
#include <irdm_common/report_template.h>

#include <irdm_common/csv.h>
#include <irdm_common/files.h>
#include <irdm_common/format.h>
#include <irdm_common/report_stamp.h>

#include <algorithm>
#include <fstream>
#include <sstream>

namespace fs = std::filesystem;

namespace irdm::validation::points
{
  namespace
  {
    /// "force rel. L2 | force max | disp. RMS | disp. max" of a table row.
    std::string
    error_cells(const Errors &e)
    {
      return fmt(e.force_rel_l2) + " | " + fmt(e.force_max) + " | " + fmt(e.disp_rms) + " | " +
             fmt(e.disp_max);
    }

    /// The scene's "comment", for the report's first paragraph.
    std::string
    scene_comment(const std::string &file)
    {
      std::ifstream     in(file);
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

    /// timestep.csv: the contact phase's probe forces, IRDM at tau and the FEM at tau/10.
    void
    write_timestep_csv(const fs::path &dir, const SceneRun &r)
    {
      const unsigned                   Nc     = r.phase.n_steps();
      std::vector<std::string>         header = {"time_s"};
      std::vector<std::vector<double>> cols(1);
      for (unsigned k = 1; k <= Nc; ++k)
        cols[0].push_back(k * r.scene.time_step);
      for (size_t p = 0; p < r.scene.probes.size(); ++p)
        for (const auto &[tag, series] :
             {std::pair<std::string, const Series *>{"irdm", &r.phase_irdm}, {"fem_fine", &r.phase_fine}})
          {
            header.push_back(r.scene.probes[p].name + "_" + tag + "_force_N");
            cols.emplace_back();
            for (unsigned k = 0; k < Nc; ++k)
              cols.back().push_back(norm(series->force[p][k]));
          }
      header.push_back("disp_rms_error_rel");
      cols.push_back(r.step_irdm.disp_rms_t);
      write_csv((dir / "timestep.csv").string(), header, cols);
    }

    /// series.csv: every probe force of the FEM and IRDM, and the errors over time.
    void
    write_series_csv(const fs::path &dir, const SceneRun &r)
    {
      std::vector<std::string>         header = {"time_s"};
      std::vector<std::vector<double>> cols(1);
      for (unsigned k = 1; k <= r.N; ++k)
        cols[0].push_back(k * r.scene.time_step);
      for (size_t p = 0; p < r.scene.probes.size(); ++p)
        for (const auto &[tag, series] :
             {std::pair<std::string, const Series *>{"fem", &r.fem_run}, {"irdm", &r.irdm_full}})
          for (int c = 0; c < 3; ++c)
            {
              header.push_back(r.scene.probes[p].name + "_" + tag + "_F" + "xyz"[c] + "_N");
              cols.emplace_back();
              for (unsigned k = 0; k < r.N; ++k)
                cols.back().push_back(series->force[p][k][c]);
            }
      header.push_back("force_error_rel");
      cols.push_back(r.exact.force_t);
      header.push_back("disp_rms_error_rel");
      cols.push_back(r.exact.disp_rms_t);
      header.push_back("disp_rms_error_rel_float");
      cols.push_back(r.exact_float.disp_rms_t);
      header.push_back("force_error_rel_T500");
      const auto t500 = std::find(r.taps.begin(), r.taps.end(), 500u);
      cols.push_back(t500 != r.taps.end() ? r.truncated[t500 - r.taps.begin()].force_t
                                          : std::vector<double>(r.N, 0.0));
      write_csv((dir / "series.csv").string(), header, cols);
    }

    void
    write_truncation_csv(const fs::path &dir, const SceneRun &r)
    {
      std::vector<std::vector<double>> cols(5);
      for (size_t i = 0; i < r.taps.size(); ++i)
        {
          cols[0].push_back(r.taps[i]);
          cols[1].push_back(r.truncated[i].force_rel_l2);
          cols[2].push_back(r.truncated[i].force_max);
          cols[3].push_back(r.truncated[i].disp_rms);
          cols[4].push_back(r.truncated[i].disp_max);
        }
      write_csv((dir / "truncation.csv").string(),
                {"T_steps", "force_rel_l2", "force_max_rel", "disp_rms_rel", "disp_max_rel"}, cols);
    }

    /// Section (f): coupling.csv and the section's text (validation/templates/coupling_sweep.md).
    std::string
    coupling_section(const fs::path &dir, const fem::Scene &scene, const CouplingSweep &c)
    {
      write_text_file((dir / "coupling.csv").string(), coupling_csv(c.runs, c.fem_peak));
      const auto         cell = [&](const CouplingRun &r) { return coupling_cell(r, c.fem_peak); };
      std::ostringstream sweep, fine;
      for (size_t i = 0; i + 1 < c.runs.size(); i += 2)
        {
          const bool rigid = c.runs[i].k == 0 && c.runs[i].b == 0;
          sweep << "| " << (rigid ? "rigid" : fmt(c.runs[i].k)) << " | "
                << (rigid ? "-" : fmt(c.runs[i].b)) << " | " << cell(c.runs[i]) << " | "
                << cell(c.runs[i + 1]) << " |\n";
        }
      for (size_t i = 0; i + 1 < c.fine.size(); i += 2)
        {
          const CouplingRun &a = c.fine[i], &f = c.fine[i + 1];
          fine << "| " << (i == 0 ? "coupled (k0, b0)" : "rigid") << " | " << cell(a) << " | "
               << cell(f) << " | "
               << (a.s.diverged_at >= 0 ? "(IRDM stopped at t = " + fmt(a.s.diverged_at) + " s)"
                                        : fmt(compare(a.s, f.s).force_rel_l2))
               << " |\n";
        }
      return fill_template(read_template("validation/templates/coupling_sweep.md"),
                           {{"k0", fmt(c.k0)},
                            {"b0", fmt(c.b0)},
                            {"tau", plain(scene.time_step)},
                            {"fem_peak", fmt(c.fem_peak)},
                            {"sweep_table", sweep.str()},
                            {"tau_fine", plain(c.fine_tau)},
                            {"fine_vertices", std::to_string(c.fine_vertices)},
                            {"fine_length", std::to_string(c.fine_length)},
                            {"fine_table", fine.str()}});
    }

    /// The probes' contact and the passivity observer of the FEM and IRDM runs.
    void
    passivity_values(const SceneRun &r, TemplateValues &v)
    {
      std::string probes;
      for (const auto &p : r.scene.probes)
        probes += "`" + p.name + "` " +
                  (p.coupling_stiffness > 0 || p.coupling_damping > 0
                     ? "coupled (k = " + fmt(p.coupling_stiffness) + " N/m, b = " +
                         fmt(p.coupling_damping) + " N s/m)"
                     : std::string("rigid")) +
                  (p.unilateral ? ", unilateral" : ", bilateral") + "; ";
      std::string table;
      for (const auto &[name, series] :
           {std::pair<std::string, const Series *>{"FEM at tau", &r.fem_run},
            {"IRDM at tau", &r.irdm_full},
            {"FEM at tau/10", &r.fem_fine_unilateral}})
        table += "| " + name + " | " + fmt(series->device_work) + " | " +
                 fmt(series->device_returned) + " |\n";
      v["probes"]          = probes;
      v["passivity_table"] = table;
    }

    std::string
    model_row(const SceneRun &r)
    {
      const auto &p = r.pre;
      return "| " + std::to_string(p.n_inputs) + " | " + std::to_string(p.n_outputs) + " | " +
             std::to_string(p.length) + " | double | " + fmt(p.bytes / 1e6) + " | " +
             fmt(p.seconds_total) + " (" + fmt(p.seconds_fem) + " / " + fmt(p.seconds_eigen) +
             " / " + fmt(p.seconds_responses) + " / " + fmt(p.seconds_write) + ") | " +
             fmt(p.energy_left_mean) + " / " + fmt(p.energy_left_max) + " | " +
             fmt(p.static_left_mean) + " / " + fmt(p.static_left_max) + " |";
    }

    TemplateValues
    scene_values(const SceneRun &r)
    {
      const fem::Scene &s = r.scene;
      std::string       truncation;
      for (size_t i = 0; i < r.taps.size(); ++i)
        truncation += "| " + std::to_string(r.taps[i]) + " | " + fmt(r.taps[i] * s.time_step) +
                      " | " + error_cells(r.truncated[i]) + " |\n";
      return {
        {"name", s.name},
        {"stamp", report_stamp()},
        {"comment", scene_comment(r.file)},
        {"version", IRDM_VERSION},
        {"file", r.file},
        {"fe_degree", std::to_string(s.fe_degree)},
        {"n_free", std::to_string(r.pre.n_free)},
        {"tau", plain(s.time_step)},
        {"steps", std::to_string(r.N)},
        {"youngs_modulus", plain(s.youngs_modulus)},
        {"poisson_ratio", plain(s.poisson_ratio)},
        {"density", plain(s.density)},
        {"rayleigh_alpha", fmt(s.rayleigh_alpha)},
        {"rayleigh_beta", fmt(s.rayleigh_beta)},
        {"lowest_hz", fmt(r.pre.lowest_frequency_hz)},
        {"lowest_damping", fmt(r.pre.lowest_damping_ratio)},
        {"model_row", model_row(r)},
        {"exact_double", error_cells(r.exact)},
        {"exact_float", error_cells(r.exact_float)},
        {"exact_check", r.pass ? "pass" : "FAIL"},
        {"truncation_table", truncation},
        {"tau_fine", plain(s.time_step / 10)},
        {"phase_duration", plain(r.phase.duration)},
        {"phase_steps", std::to_string(r.phase.n_steps())},
        {"step_irdm", error_cells(r.step_irdm)},
        {"step_fem", error_cells(r.step_fem)},
        {"peak_fine", fmt(r.peak_fine)},
        {"peak_coarse", fmt(r.peak_coarse)},
        {"fine_diverged", !r.fine_finite || r.peak_fine > 100 * r.peak_coarse ? "1" : ""},
        {"output_vertices", std::to_string(r.n_outputs / 3)},
        {"force_loop_us", fmt(1e6 * r.irdm_force.force_loop_seconds)},
        {"surface_us", fmt(1e6 * r.irdm_full.surface_seconds)},
        {"fem_ms", fmt(1e3 * r.fem_run.step_seconds)},
        {"h_float_mb", fmt(4.0 * r.n_inputs * r.n_outputs * r.length / 1e6)},
        {"compression_section", compression_section(r.compression, r.n_outputs)},
      };
    }

    /// Per scene and compressor: the smallest model that meets the goal (disp. RMS <= 1 %,
    /// force rel. L2 <= 2 %, stable), and the unstable settings.
    std::string
    compression_table(const std::vector<std::pair<std::string, std::vector<CompressionRow>>> &scenes)
    {
      std::ostringstream md;
      for (const auto &[name, rows] : scenes)
        for (const char *method : {"representatives", "interpolated", "modal", "era", "balanced"})
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
      return md.str();
    }

    /// The full model's part of validation.md (empty values when it did not run).
    void
    full_model_values(const std::optional<FullModelRun> &full, TemplateValues &v)
    {
      const char *keys[] = {"sampled", "stride", "length", "n_inputs", "n_outputs", "mb",
                            "seconds_total", "seconds_fem", "n_free", "seconds_eigen",
                            "seconds_responses", "seconds_write", "ranks", "energy_left_mean",
                            "energy_left_max", "static_left_mean", "static_left_max",
                            "waveforms", "table1", "scene", "compression_section"};
      v["full_model"] = full ? "1" : "";
      for (const char *k : keys)
        v[k] = "";
      if (!full)
        return;
      const auto &p = full->pre;
      const char *labels[7] = {"number of representative data", "number of non-representative data",
                               "compression ratio (representatives / waveforms)",
                               "data size of the representatives (GB)",
                               "data size with the delay/amplitude tables (GB, % of float H)",
                               "compression time (s, 2 threads)",
                               "mean fit correlation / mean delay (steps)"};
      const std::string original[7] = {"-", "-", "100.0%", fmt(full->h_bytes / 1e9, "%.3f"),
                                       fmt(full->h_bytes / 1e9, "%.3f"), "-", "-"};
      std::string table1;
      for (int i = 0; i < 7; ++i)
        {
          table1 += "| " + std::string(labels[i]);
          for (const auto &c : full->table1[i])
            table1 += " | " + c;
          table1 += " | " + original[i] + " |\n";
        }
      v["sampled"]           = full->stride > 1 ? "1" : "";
      v["stride"]            = std::to_string(full->stride);
      v["length"]            = std::to_string(p.length);
      v["n_inputs"]          = std::to_string(p.n_inputs);
      v["n_outputs"]         = std::to_string(p.n_outputs);
      v["mb"]                = fmt(p.bytes / 1e6);
      v["seconds_total"]     = fmt(p.seconds_total);
      v["seconds_fem"]       = fmt(p.seconds_fem);
      v["n_free"]            = std::to_string(p.n_free);
      v["seconds_eigen"]     = fmt(p.seconds_eigen);
      v["seconds_responses"] = fmt(p.seconds_responses);
      v["seconds_write"]     = fmt(p.seconds_write);
      v["ranks"]             = std::to_string(p.ranks);
      v["energy_left_mean"]  = fmt(p.energy_left_mean);
      v["energy_left_max"]   = fmt(p.energy_left_max);
      v["static_left_mean"]  = fmt(p.static_left_mean);
      v["static_left_max"]   = fmt(p.static_left_max);
      v["waveforms"]         = fmt(full->waveforms, "%.0f");
      v["table1"]            = table1;
      v["scene"]             = full->scene;
      v["compression_section"] = compression_section(full->rows, full->n_outputs);
    }
  } // namespace

  void
  write_scene_report(const fs::path &dir, const SceneRun &r)
  {
    fs::create_directories(dir);
    write_timestep_csv(dir, r);
    write_series_csv(dir, r);
    write_truncation_csv(dir, r);
    write_compression_csv((dir / "compression.csv").string(), r.compression);
    TemplateValues v = scene_values(r);
    passivity_values(r, v);
    v["coupling_section"] = r.coupling ? coupling_section(dir, r.scene, *r.coupling) : "";
    write_text_file((dir / "report.md").string(), fill_template(read_template("validation/templates/scene.md"), v));
  }

  std::string
  summary_row(const SceneRun &r)
  {
    const auto &p = r.pre;
    return "| [" + r.scene.name + "](" + r.scene.name + "/report.md) | " + std::to_string(r.N) +
           " | " + std::to_string(r.scene.probes.size()) + " | " + std::to_string(p.n_inputs) +
           " x " + std::to_string(p.n_outputs) + " x " + std::to_string(p.length) + " | " +
           fmt(p.seconds_total) + " | " + fmt(p.bytes / 1e6) + " | " + error_cells(r.exact) +
           " | " + fmt(r.exact_float.force_rel_l2) + " / " + fmt(r.exact_float.disp_max) + " | " +
           fmt(1e6 * r.irdm_force.force_loop_seconds) + " | " +
           fmt(1e6 * r.irdm_full.surface_seconds) + " | " + fmt(1e3 * r.fem_run.step_seconds) +
           " |\n";
  }

  void
  write_validation_summary(const PointValidationOptions &o, const std::string &scenes_table,
                           const std::vector<std::pair<std::string, std::vector<CompressionRow>>> &compression,
                           const std::optional<FullModelRun> &full)
  {
    TemplateValues v{{"stamp", report_stamp()},
                     {"scenes_table", scenes_table},
                     {"compression_table", compression_table(compression)}};
    full_model_values(full, v);
    if (full)
      write_compression_csv((fs::path(o.report_dir) / "full_model_compression.csv").string(), full->rows);
    write_text_file((fs::path(o.report_dir) / "validation.md").string(),
                    fill_template(read_template("validation/templates/validation.md"), v));
  }
} // namespace irdm::validation::points
