// The free-body study's report (free_body_runs.h): the CSV files other programs read, and
// report.md from validation/templates/free.md.
#include "free_body_runs.h"
#include <irdm_common/report_template.h>

#include <irdm_common/files.h>
#include <irdm_common/format.h>
#include <irdm_common/report_stamp.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <tuple>

namespace fs = std::filesystem;

namespace irdm::validation::free_body
{
  namespace
  {
    void
    write(const std::string &dir, const std::string &name, const std::string &text)
    {
      write_text_file((fs::path(dir) / name).string(), text);
    }

    /// The impact study's lines (impact.csv): every run against the truth, and the runtime
    /// against the linear FEM, over the first contact, by speed.
    struct ImpactLine
    {
      std::string c, method, reference;
      double      E, v, start, end, force, impulse, deformation; // over the first contact
      double      run_force, run_impulse, run_deformation, run_angle; // over the whole run
    };

    std::vector<ImpactLine>
    impact_lines(const FreeStudy &s)
    {
      std::vector<ImpactLine> impact;
      for (const Row &r : s.rows)
        if (r.impact_speed > 0 && r.fem_failed.empty())
          impact.push_back({r.c, r.method, "fem_neo_hookean", r.E, r.impact_speed, r.first_start,
                            r.first_end, r.first_force_error, r.first_impulse_error,
                            r.first_deformation_error, r.force_error, r.impulse_error,
                            r.deformation_error, r.angle_error});
      for (const LinearizationRow &r : s.linearization)
        if (r.impact_speed > 0 && r.failed.empty())
          impact.push_back({r.c, r.method, r.reference, r.E, r.impact_speed, r.start, r.end,
                            r.errors.window_force, r.errors.window_impulse,
                            r.errors.window_deformation, r.errors.force, r.errors.impulse,
                            r.errors.deformation, r.errors.angle});
      std::stable_sort(impact.begin(), impact.end(), [](const ImpactLine &a, const ImpactLine &b) {
        return std::tie(a.E, a.v, a.reference) < std::tie(b.E, b.v, b.reference);
      });
      return impact;
    }

    /// free.csv and its table (the impact study's rows go to impact.csv).
    void
    free_rows(const FreeStudy &s, std::ostringstream &csv, std::ostringstream &md)
    {
      csv << "case,material,method,com_error,angle_error_deg,force_error,impulse_error,"
             "deformation_error,irdm_us_per_step,fem_ms_per_step,stable,method_force_error,"
             "method_impulse_error,method_deformation_error\n";
      for (const Row &r : s.rows)
        {
          if (r.impact_speed > 0)
            continue;
          csv << r.c << ',' << material_name(r.E) << ',' << r.method << ',';
          md << "| " << r.c << " | " << material_name(r.E) << " | " << r.method;
          if (!r.fem_failed.empty())
            {
              csv << "nan,nan,nan,nan,nan,nan,nan,fem_failed,nan,nan,nan\n";
              md << " | the FEM failed: " << r.fem_failed << " ||||||||||\n";
              continue;
            }
          csv << r.com_error << ',' << r.angle_error << ',' << r.force_error << ','
              << r.impulse_error << ',' << r.deformation_error << ',' << r.irdm_us << ','
              << r.fem_ms << ',' << (r.stable ? "yes" : "no") << ',' << r.method_force_error << ','
              << r.method_impulse_error << ',' << r.method_deformation_error << '\n';
          md << " | " << r.com_error << " | " << r.angle_error << " | " << r.force_error << " | "
             << r.impulse_error << " | " << r.peak_ratio << " | " << r.deformation_error << " | "
             << r.rotation_deg << " / " << r.turned_deg << " | " << r.centrifugal << " | "
             << r.irdm_us << " | " << r.fem_ms << " | " << (r.stable ? "yes" : "no") << " |\n";
        }
    }

    /// first_contact.csv and its table.
    void
    first_contact_rows(const FreeStudy &s, std::ostringstream &csv, std::ostringstream &md)
    {
      csv << "case,material,method,start_s,end_s,force_error,impulse_error,deformation_error\n";
      for (const Row &r : s.rows)
        if (r.impact_speed == 0 && r.fem_failed.empty() && r.first_end > r.first_start)
          {
            csv << r.c << ',' << material_name(r.E) << ',' << r.method << ',' << r.first_start
                << ',' << r.first_end << ',' << r.first_force_error << ','
                << r.first_impulse_error << ',' << r.first_deformation_error << '\n';
            md << "| " << r.c << " | " << material_name(r.E) << " | " << r.method << " | "
               << r.first_start << " to " << r.first_end << " | " << r.first_force_error << " | "
               << r.first_impulse_error << " | " << r.first_deformation_error << " |\n";
          }
    }

    /// truth_strain.csv and its table.
    void
    strain_rows(const FreeStudy &s, std::ostringstream &csv, std::ostringstream &md)
    {
      csv << "case,material,impact_speed_m_s,start_s,end_s,first_largest_strain,"
             "first_strained_volume_fraction,run_largest_strain\n";
      for (const StrainRow &r : s.strain)
        {
          csv << r.c << ',' << material_name(r.E) << ',' << r.impact_speed << ',' << r.start << ','
              << r.end << ',' << r.first_largest << ',' << r.first_fraction << ',' << r.run_largest
              << '\n';
          md << "| " << r.c << " | " << material_name(r.E) << " | " << r.start << " to " << r.end
             << " | " << r.first_largest << " | " << r.first_fraction << " | " << r.run_largest
             << " |\n";
        }
    }

    /// linearization.csv and its table (the impact study's rows go to impact.csv).
    void
    linearization_rows(const FreeStudy &s, std::ostringstream &csv, std::ostringstream &md)
    {
      csv << "case,material,method,reference,start_s,end_s,fem_rotation_deg,first_force_error,"
             "first_impulse_error,first_deformation_error,com_error,angle_error_deg,force_error,"
             "impulse_error,deformation_error,fem_ms_per_step\n";
      for (const LinearizationRow &r : s.linearization)
        {
          if (r.impact_speed > 0)
            continue;
          csv << r.c << ',' << material_name(r.E) << ',' << r.method << ',' << r.reference << ','
              << r.start << ',' << r.end << ',' << r.rotation_deg << ',';
          md << "| " << r.c << " | " << material_name(r.E) << " | " << r.method << " | "
             << r.reference << " | " << r.start << " to " << r.end << " | " << r.rotation_deg
             << " | ";
          const RunErrors &e = r.errors;
          if (!r.failed.empty())
            {
              csv << "nan,nan,nan,nan,nan,nan,nan,nan,nan\n";
              md << "the FEM failed: " << r.failed << " |||||||\n";
              continue;
            }
          csv << e.window_force << ',' << e.window_impulse << ',' << e.window_deformation << ','
              << e.com << ',' << e.angle << ',' << e.force << ',' << e.impulse << ','
              << e.deformation << ',' << r.fem_ms << '\n';
          md << e.window_force << " | " << e.window_impulse << " | " << e.window_deformation
             << " | " << e.com << " | " << e.angle << " | " << e.deformation << " | ";
          if (r.fem_ms > 0)
            md << r.fem_ms;
          md << " |\n";
        }
    }

    /// impact.csv and its table.
    void
    impact_rows(const std::vector<ImpactLine> &impact, const double density,
                std::ostringstream &csv, std::ostringstream &md)
    {
      csv << "case,material,speed_m_s,speed_over_wave_speed,method,reference,start_s,end_s,"
             "first_force_error,first_impulse_error,first_deformation_error,force_error,"
             "impulse_error,deformation_error,angle_error_deg\n";
      for (const ImpactLine &l : impact)
        {
          const double ratio = l.v / std::sqrt(l.E / density);
          csv << l.c << ',' << material_name(l.E) << ',' << l.v << ',' << ratio << ',' << l.method
              << ',' << l.reference << ',' << l.start << ',' << l.end << ',' << l.force << ','
              << l.impulse << ',' << l.deformation << ',' << l.run_force << ',' << l.run_impulse
              << ',' << l.run_deformation << ',' << l.run_angle << '\n';
          md << "| " << material_name(l.E) << " | " << l.v << " | " << ratio << " | " << l.method
             << " | " << l.reference << " | " << l.start << " to " << l.end << " | " << l.force
             << " | " << l.impulse << " | " << l.deformation << " | " << l.run_force << " | "
             << l.run_deformation << " | " << l.run_angle << " |\n";
        }
    }

    /// truth.csv and its table.
    void
    truth_rows(const FreeStudy &s, std::ostringstream &csv, std::ostringstream &md)
    {
      csv << "case,material,com_error,angle_error_deg,force_error,impulse_error,"
             "deformation_error,fem_half_step_ms_per_tau\n";
      for (const TruthRow &r : s.truth)
        {
          const RunErrors &he = r.errors;
          if (!r.failed.empty())
            {
              csv << r.c << ',' << material_name(r.E) << ",nan,nan,nan,nan,nan,nan\n";
              md << "| " << r.c << " | " << material_name(r.E)
                 << " | the FEM at tau / 2M failed: " << r.failed << " ||||||\n";
              continue;
            }
          csv << r.c << ',' << material_name(r.E) << ',' << he.com << ',' << he.angle << ','
              << he.force << ',' << he.impulse << ',' << he.deformation << ',' << r.half_ms << '\n';
          md << "| " << r.c << " | " << material_name(r.E) << " | " << he.com << " | " << he.angle
             << " | " << he.force << " | " << he.impulse << " | " << he.deformation << " | "
             << r.half_ms << " |\n";
        }
    }

    std::string
    stability_table(const FreeStudy &s)
    {
      std::ostringstream md;
      for (const StabilityRow &r : s.stability)
        if (r.flight)
          md << "| " << r.run << " | " << material_name(r.E) << " | " << r.method << " | "
             << r.growth << " | | | 0 | | | |\n";
        else
          md << "| " << r.run << " | " << material_name(r.E) << " | " << r.method << " | "
             << r.growth << " | " << r.turned << " | " << r.final_growth << " | " << r.failed
             << " (" << r.limited << ") | " << r.contact_limited << " / " << r.contact_fallback
             << " | " << r.deepest << " | " << r.us << " |\n";
      return md.str();
    }

    std::string
    free_flight_list(const FreeStudy &s)
    {
      std::ostringstream md;
      for (const FreeFlight &f : s.free_flight)
        md << "- " << f.material << f.what << ": linear momentum within " << f.momentum
           << " of p0 + m g t (relative to |p0|), angular momentum within " << f.angular_momentum
           << " of L0, energy gain " << f.growth << " of the initial kinetic energy, the "
           << "deformation's energy " << f.elastic_energy << " J\n";
      return md.str();
    }

    unsigned
    fem_divisions_of(const FreeBodyValidationOptions &o, const size_t m)
    {
      return o.fem_divisions.size() == 1 ? o.fem_divisions[0] : o.fem_divisions[m];
    }

    /// The command line that made the report (the options that change what it shows).
    std::string
    command_of(const FreeBodyValidationOptions &o)
    {
      std::ostringstream c;
      c << "irdm validate-free" << (o.quick ? " --quick" : "") << " --fem-divisions ";
      for (size_t m = 0; m < o.fem_divisions.size(); ++m)
        c << (m ? "," : "") << o.fem_divisions[m];
      c << (o.reuse_models ? " --reuse-models" : "") << (o.truth_check ? " --truth-check" : "")
        << (o.sensitivity ? " --sensitivity" : "");
      if (o.sensitivity && o.sensitivity_um != std::vector<double>{1})
        {
          c << " --sensitivity-um";
          for (const double um : o.sensitivity_um)
            c << ' ' << plain(um);
        }
      c
        << (o.surface_modes ? " --surface-modes " + std::to_string(o.surface_modes) : std::string())
        << (o.small_strain ? "" : " --no-small-strain")
        << (o.small_strain && !o.body_frame ? " --linear-law linear" : "")
        << (o.corotational ? "" : " --no-corotational")
        << (o.centrifugal ? " --centrifugal" : "") << (o.deformed_inertia ? " --deformed-inertia" : "")
        << (o.frame_forces ? " --frame-forces" : "")
        << (o.deformation_momentum ? " --deformation-momentum" : "")
        << ((o.frame_forces || o.deformation_momentum) && o.frame_modes > 0 ? " --frame-modes " + std::to_string(o.frame_modes) : "")
        << " --converged-degree " << o.converged_degree;
      if (o.converged_degree > 0)
        {
          c << " --converged-cases";
          for (const auto &name : o.converged_cases)
            c << ' ' << name;
          if (!o.converged_mesh.empty())
            c << " --converged-mesh " << o.converged_mesh;
          if (!o.converged_check_meshes.empty())
            c << " --converged-check-mesh";
          for (const auto &mesh : o.converged_check_meshes)
            c << ' ' << mesh;
        }
      return c.str();
    }

    TemplateValues
    prose_values(const FreeBodyValidationOptions &o, const fem::Scene &base)
    {
      std::ostringstream fem_steps;
      for (size_t m = 0; m < o.materials.size(); ++m)
        fem_steps << (m ? ", " : "") << base.time_step * 1e3 / fem_divisions_of(o, m) << " ms at "
                  << material_name(o.materials[m]);
      return {{"stamp", report_stamp()},
              {"command", command_of(o)},
              {"scene", o.scene},
              {"tau_ms", plain(base.time_step * 1e3)},
              {"duration", plain(o.duration)},
              {"fem_steps", fem_steps.str()},
              {"surface_modes", o.surface_modes == 0 ? "every mode" : std::to_string(o.surface_modes)},
              {"force_modes", o.force_modes > 0 ? std::to_string(o.force_modes) : ""},
              {"vdof", o.vdof_subdivisions >= 0 ? "1" : ""},
              {"vdof_subdivisions", std::to_string(o.vdof_subdivisions)},
              {"vdof_length", std::to_string(o.vdof_length)},
              {"centrifugal", o.centrifugal ? "1" : ""},
              {"deformed_inertia", o.deformed_inertia ? "1" : ""},
              {"frame_forces", o.frame_forces ? "1" : ""},
              {"deformation_momentum", o.deformation_momentum ? "1" : ""},
              {"small_strain", o.small_strain ? "1" : ""},
              {"body_frame", o.body_frame ? "1" : ""},
              {"truth_check", o.truth_check ? "1" : ""},
              {"sensitivity", o.sensitivity ? "1" : ""},
              {"corotational", o.corotational ? "1" : ""},
              {"converged", o.converged_degree > 0 && !o.converged_cases.empty() ? "1" : ""},
              {"converged_degree", std::to_string(o.converged_degree)},
              {"converged_mesh", o.converged_mesh.empty() ? "" : std::filesystem::path(o.converged_mesh).filename().string()},
              {"converged_truth", converged_truth_name(o)},
              {"linear_fem", o.body_frame ? "fem_linear_body_frame" : "fem_small_strain"},
              {"study_surface_modes", std::to_string(o.study_surface_modes)},
              {"stability_seconds", plain(o.stability_seconds)}};
    }
  } // namespace

  FreeTables
  write_free_csvs(const std::string &dir, const FreeBodyValidationOptions &o, const FreeStudy &s,
                  const double density)
  {
    std::ostringstream csv, free_md, first_csv, first_md, strain_csv, strain_md, lin_csv, lin_md,
      impact_csv, impact_md, truth_csv, truth_md;
    free_rows(s, csv, free_md);
    write(dir, "free.csv", csv.str());
    first_contact_rows(s, first_csv, first_md);
    write(dir, "first_contact.csv", first_csv.str());
    strain_rows(s, strain_csv, strain_md);
    write(dir, "truth_strain.csv", strain_csv.str());
    linearization_rows(s, lin_csv, lin_md);
    if (o.small_strain || o.corotational || !s.linearization.empty()) // the converged truth's too
      write(dir, "linearization.csv", lin_csv.str());
    const auto impact = impact_lines(s);
    impact_rows(impact, density, impact_csv, impact_md);
    if (!impact.empty())
      write(dir, "impact.csv", impact_csv.str());
    truth_rows(s, truth_csv, truth_md);
    if (o.truth_check)
      write(dir, "truth.csv", truth_csv.str());
    std::ostringstream tri;
    tri << "a,b,c\n";
    for (const auto &t : s.triangles)
      tri << t[0] << ',' << t[1] << ',' << t[2] << '\n';
    write(dir, "series.csv", s.series.str());
    write(dir, "stability.csv", s.stability_csv.str());
    write(dir, "frames.csv", s.frames.str());
    write(dir, "triangles.csv", tri.str());
    return {free_md.str(), first_md.str(), strain_md.str(), lin_md.str(), impact_md.str(),
            truth_md.str()};
  }

  void
  write_free_report(const std::string &dir, const FreeBodyValidationOptions &o,
                    const FreeStudy &s, const fem::Scene &base, const FreeTables &t)
  {
    TemplateValues v = prose_values(o, base);
    for (const char *chart : charts) // "fig6_png": shown when drawn
      v[std::string(chart).replace(std::string(chart).find('.'), 1, "_")] =
        fs::exists(fs::path(dir) / chart) ? "1" : "";
    v["impact"]              = t.impact.empty() ? "" : "1";
    v["free_table"]          = t.free;
    v["first_table"]         = t.first_contact;
    v["strain_table"]        = t.strain;
    v["linearization_table"] = t.linearization;
    v["truth_table"]         = t.truth;
    v["impact_table"]        = t.impact;
    v["stability_table"]     = stability_table(s);
    v["free_flight"]         = free_flight_list(s);
    write(dir, "report.md", fill_template(read_template("validation/templates/free.md"), v));
  }
} // namespace irdm::validation::free_body
