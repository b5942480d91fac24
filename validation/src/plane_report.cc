// The plane study's report (plane_runs.h): the CSV files other programs read, and planes.md
// from validation/templates/planes.md.
#include "plane_runs.h"
#include <irdm_common/report_template.h>

#include <irdm_common/files.h>
#include <irdm_common/format.h>
#include <irdm_common/report_stamp.h>

#include <cstdio>
#include <filesystem>
#include <sstream>

namespace fs = std::filesystem;

namespace irdm::validation::planes
{
  namespace
  {
    std::string
    vec_text(const Vec3 &v)
    {
      char b[80];
      std::snprintf(b, sizeof b, "(%.3f, %.3f, %.3f)", v[0], v[1], v[2]);
      return b;
    }

    std::string
    percent(const double x)
    {
      return fmt(100 * x) + " %";
    }

    void
    write_csv(const std::string &dir, const std::string &name, const std::ostringstream &csv)
    {
      write_text_file((fs::path(dir) / name).string(), csv.str());
    }

    void
    write_mapping_csv(const std::string &dir, const std::vector<MappingRow> &mapping)
    {
      std::ostringstream csv;
      csv << "case,distinct_first_contacts,first_contact_spread_m,feedthrough_ratio,"
             "static_compliance_ratio,nearest_impulse_error,interpolated_impulse_error,"
             "nearest_displacement_error,interpolated_displacement_error,"
             "same_contact_impulse_error,same_contact_displacement_error,same_contact_force_error,"
             "open_loop_displacement_error\n";
      for (const auto &m : mapping)
        csv << m.name << "," << m.distinct_first_contacts << "," << m.spread << ","
            << m.feedthrough_ratio << "," << m.static_ratio << ","
            << m.row->method[0].impulse_error << "," << m.row->method[1].impulse_error << ","
            << m.row->method[0].displacement_error << "," << m.row->method[1].displacement_error
            << "," << m.row->same_contact.impulse_error << ","
            << m.row->same_contact.displacement_error << "," << m.row->same_contact.force_error
            << "," << m.row->open_loop_displacement_error << "\n";
      write_csv(dir, "mapping.csv", csv);
    }

    void
    write_stiffness_csv(const std::string &dir, const std::vector<SweepRow> &sweep)
    {
      std::ostringstream csv;
      csv << "case,method,stiffness_N_m,fem_equivalent,force_error,impulse_error,"
             "displacement_error,max_penetration_m,contact_vertices_max,stable\n";
      for (const auto &w : sweep)
        csv << w.c << "," << w.method << "," << w.k << "," << (w.fem_equivalent ? 1 : 0) << ","
            << w.result.force_error << "," << w.result.impulse_error << ","
            << w.result.displacement_error << "," << w.result.max_penetration << ","
            << w.result.contact_vertices_max << "," << (w.result.stable ? 1 : 0) << "\n";
      write_csv(dir, "stiffness.csv", csv);
    }

    /// Every method that ran on the case, by name: the table's methods, then the reduced
    /// nonlinear models.
    std::vector<std::pair<std::string, const MethodResult *>>
    ran_methods(const Row &r)
    {
      std::vector<std::pair<std::string, const MethodResult *>> out;
      for (size_t m = 0; m < method_names.size(); ++m)
        if (r.method[m].ran)
          out.emplace_back(method_names[m], &r.method[m]);
      for (const auto &[name, x] : r.reduced)
        if (x.ran)
          out.emplace_back(name, &x);
      return out;
    }

    void
    write_planes_csv(const std::string &dir, const std::vector<Row> &rows)
    {
      std::ostringstream csv;
      csv << "case,method,force_error,impulse_error,displacement_error,contact_vertices_max,"
             "force_us_per_step,surface_us_per_step,fem_ms_per_step,stable\n";
      for (const auto &r : rows)
        for (const auto &[name, x] : ran_methods(r))
          {
            csv << r.c.name << "," << name << "," << x->force_error << "," << x->impulse_error
                << "," << x->displacement_error << ",";
            if (x->contact_vertices_max >= 0)
              csv << x->contact_vertices_max;
            csv << "," << x->force_us << "," << x->surface_us << "," << r.fem_ms_per_step << ","
                << (x->stable ? 1 : 0) << "\n";
          }
      write_csv(dir, "planes.csv", csv);
    }

    /// spread.csv: each error and its range under the perturbations.
    void
    write_spread_csv(const std::string &dir, const std::vector<Row> &rows, const unsigned runs)
    {
      std::ostringstream csv;
      csv << "case,method,runs,force_error,force_error_min,force_error_max,impulse_error,"
             "impulse_error_min,impulse_error_max,displacement_error,displacement_error_min,"
             "displacement_error_max\n";
      for (const auto &r : rows)
        for (size_t m = 0; m < method_names.size(); ++m)
          {
            const MethodResult &x = r.method[m];
            if (!x.ran || x.force_range.empty())
              continue;
            csv << r.c.name << "," << method_names[m] << "," << runs << "," << x.force_error << ","
                << x.force_range.lo << "," << x.force_range.hi << "," << x.impulse_error << ","
                << x.impulse_range.lo << "," << x.impulse_range.hi << "," << x.displacement_error
                << "," << x.displacement_range.lo << "," << x.displacement_range.hi << "\n";
          }
      write_csv(dir, "spread.csv", csv);
    }

    /// A figure that does not hold still: it ranges over more than a tenth of its own size,
    /// and over more than 0.5 % points, five times what the largest perturbation (1e-3) can
    /// move a relative error that follows the scene smoothly.
    bool
    moves(const Range &r)
    {
      return !r.empty() && r.hi - r.lo > std::max(0.1 * r.hi, 5e-3);
    }

    std::string
    range(const Range &r)
    {
      return fmt(100 * r.lo) + " to " + fmt(100 * r.hi) + " %";
    }

    /// An error as the tables print it: its range where it does not hold still, else the
    /// figure.
    std::string
    figure(const double x, const Range &r)
    {
      return moves(r) ? range(r) : percent(x);
    }

    /// The figure a choice between methods goes by: the worst of the perturbed runs where
    /// there were some, so that the choice does not follow one draw.
    double
    worst(const double x, const Range &r)
    {
      return r.empty() ? x : std::max(x, r.hi);
    }

    /// The figures that do not hold still, with their ranges.
    std::string
    spread_table(const std::vector<Row> &rows)
    {
      std::ostringstream md;
      for (const auto &r : rows)
        for (size_t m = 0; m < method_names.size(); ++m)
          {
            const MethodResult &x = r.method[m];
            if (x.ran && (moves(x.force_range) || moves(x.impulse_range) || moves(x.displacement_range)))
              md << "| " << r.c.name << " | " << method_names[m] << " | " << range(x.force_range)
                 << " | " << range(x.impulse_range) << " | " << range(x.displacement_range) << " |\n";
          }
      return md.str();
    }

    void
    write_cases_csv(const std::string &dir, const std::vector<Row> &rows)
    {
      std::ostringstream csv;
      csv << "case,kind,walls,dx,dy,dz,on_dome,depth_m,speed_m_s,fem_peak_force_N,"
             "fem_max_penetration_m,open_loop_displacement_error,fem_newton_iterations,"
             "vertex_stiffness_N_m,linear_fem_force_error,linear_fem_impulse_error,"
             "linear_fem_displacement_error,linear_law_force_error,linear_law_impulse_error,"
             "linear_law_displacement_error,corotational_force_error,corotational_impulse_error,"
             "corotational_displacement_error,rotation_force_error,rotation_impulse_error,"
             "rotation_displacement_error,fem_ms_per_step,linear_law_ms_per_step,"
             "corotational_ms_per_step\n";
      for (const auto &r : rows)
        {
          csv << r.c.name << "," << r.c.kind << "," << r.c.d.size() << "," << r.c.d[0][0] << ","
              << r.c.d[0][1] << "," << r.c.d[0][2] << "," << r.on_dome << "," << r.c.depth << ","
              << r.c.speed << "," << r.fem_peak_force << "," << r.fem_max_penetration << ","
              << r.open_loop_displacement_error << "," << r.newton << "," << r.vertex_stiffness
              << ",";
          if (r.linear_fem.ran)
            csv << r.linear_fem.force_error << "," << r.linear_fem.impulse_error << ","
                << r.linear_fem.displacement_error;
          else
            csv << ",,";
          for (const MethodResult *m : {&r.linear_law, &r.corotational, &r.rotation})
            if (m->ran)
              csv << "," << m->force_error << "," << m->impulse_error << "," << m->displacement_error;
            else
              csv << ",,,";
          csv << "," << r.fem_ms_per_step << ",";
          if (r.linear_law.ran)
            csv << r.linear_law_ms;
          csv << ",";
          if (r.corotational.ran)
            csv << r.corotational_ms;
          csv << "\n";
        }
      write_csv(dir, "cases.csv", csv);
    }

    // Every run scored against the converged truth where it ran: name and result, in order.
    std::vector<std::pair<std::string, const MethodResult *>>
    converged_runs(const Row &r)
    {
      std::vector<std::pair<std::string, const MethodResult *>> out;
      for (size_t j = 0; j < method_names.size(); ++j)
        out.emplace_back(method_names[j], &r.method[j]);
      out.emplace_back("vdof_interpolated_same_contact", &r.same_contact);
      out.emplace_back("fem_linear_vertex_contact", &r.linear_fem);
      out.emplace_back("fem_small_strain", &r.linear_law);
      out.emplace_back("fem_corotational", &r.corotational);
      return out;
    }

    /// converged.csv and its table: the P1 truth and every run against the converged truth.
    std::string
    converged_results(const std::string &dir, const std::vector<Row> &rows)
    {
      std::ostringstream csv, md;
      csv << "case,method,force_error,impulse_error,displacement_error,converged_force_error,"
             "converged_impulse_error,converged_displacement_error,converged_degree,"
             "converged_dofs,converged_ms_per_step,converged_truth\n";
      bool any = false;
      for (const auto &r : rows)
        {
          if (r.converged_degree == 0)
            continue;
          any               = true;
          const auto suffix = "," + std::to_string(r.converged_degree) + "," +
                              std::to_string(r.converged_dofs) + "," + fmt(r.converged_ms) +
                              "," + r.converged_truth + "\n";
          csv << r.c.name << ",fem_neo_hookean_p1,0,0,0," << r.truth_force_error << ","
              << r.truth_impulse_error << "," << r.truth_displacement_error << suffix;
          md << "| " << r.c.name << " | P1 truth (fem_neo_hookean) | 0 / 0 / 0 | "
             << fmt(100 * r.truth_force_error) << " / " << fmt(100 * r.truth_impulse_error) << " / "
             << percent(r.truth_displacement_error) << " |\n";
          for (const auto &[name, m] : converged_runs(r))
            {
              if (!m->ran || m->converged_force_error < 0)
                continue;
              csv << r.c.name << "," << name << "," << m->force_error << "," << m->impulse_error
                  << "," << m->displacement_error << "," << m->converged_force_error << ","
                  << m->converged_impulse_error << "," << m->converged_displacement_error << suffix;
              md << "| " << r.c.name << " | " << name << " | " << fmt(100 * m->force_error) << " / "
                 << fmt(100 * m->impulse_error) << " / " << percent(m->displacement_error) << " | "
                 << fmt(100 * m->converged_force_error) << " / "
                 << fmt(100 * m->converged_impulse_error) << " / "
                 << percent(m->converged_displacement_error) << " |\n";
            }
        }
      if (any)
        write_csv(dir, "converged.csv", csv);
      return md.str();
    }

    void
    write_forces_csv(const std::string &dir, const std::vector<Row> &rows, const double tau)
    {
      std::ostringstream csv;
      csv << "case,time_s,penetration_m,fem_force_N";
      for (const auto *m : method_names)
        csv << "," << m << "_force_N";
      if (!rows.empty()) // the reduced models, the same on every case
        for (const auto &named : rows.front().reduced)
          csv << "," << named.first << "_force_N";
      csv << "\n";
      for (const auto &r : rows)
        for (std::size_t k = 1; k < r.F_fem.size(); ++k)
          {
            csv << r.c.name << "," << k * tau << "," << interp(r.c.times, r.c.penetration, k * tau)
                << "," << r.F_fem[k];
            const auto cell = [&](const MethodResult &m) {
              csv << ",";
              if (m.ran)
                csv << m.F[k - 1];
            };
            for (const auto &m : r.method)
              cell(m);
            for (const auto &named : r.reduced)
              cell(named.second);
            csv << "\n";
          }
      write_csv(dir, "forces.csv", csv);
    }

    void
    write_coupling_csv(const std::string &dir, const PlateStudy &plate)
    {
      write_text_file((fs::path(dir) / "coupling.csv").string(),
                      coupling_csv(plate.runs, plate.rigid_peak));
    }

    std::string
    optional_count(const int n)
    {
      return n >= 0 ? std::to_string(n) : "";
    }

    /// The main table: one row per case and method.
    std::string
    methods_table(const std::vector<Row> &rows)
    {
      std::ostringstream md;
      md.precision(3);
      for (const auto &r : rows)
        {
          bool first = true;
          for (const auto &[name, x] : ran_methods(r))
            {
              md << "| " << (first ? r.c.name : "") << " | "
                 << (first ? std::to_string(r.fem_peak_force).substr(0, 6) : "") << " | "
                 << (first ? std::to_string(1e3 * r.fem_max_penetration).substr(0, 6) : "")
                 << " | " << name << " | " << figure(x->force_error, x->force_range) << " | "
                 << figure(x->impulse_error, x->impulse_range) << " | "
                 << figure(x->displacement_error, x->displacement_range) << " | "
                 << optional_count(x->contact_vertices_max) << " | "
                 << optional_count(x->candidates_max) << " | " << optional_count(x->rounds_max)
                 << " | " << x->force_us << " | " << x->surface_us << " | "
                 << (x->stable ? "yes" : "**no**") << " |\n";
              first = false;
            }
        }
      return md.str();
    }

    /// The open-loop, linear-FEM and linear-law tables.
    void
    reference_tables(const std::vector<Row> &rows, TemplateValues &v)
    {
      std::ostringstream open, lin, law, split;
      lin.precision(3);
      for (const auto &r : rows)
        {
          if (r.open_loop_displacement_error >= 0)
            open << "| " << r.c.name << " | " << percent(r.open_loop_displacement_error) << " |\n";
          // The linear FEM runs once; where vertex_contact_direct, its exact equal, does not
          // hold still, its figures are one draw of the same range.
          const MethodResult &direct = r.method[3];
          const bool          drawn  = direct.ran && (moves(direct.force_range) ||
                                                      moves(direct.impulse_range) ||
                                                      moves(direct.displacement_range));
          if (r.linear_fem.ran)
            lin << "| " << r.c.name << (drawn ? " (one draw)" : "") << " | "
                << percent(r.linear_fem.force_error) << " | "
                << percent(r.linear_fem.impulse_error) << " | "
                << percent(r.linear_fem.displacement_error) << " | "
                << figure(r.method[2].displacement_error, r.method[2].displacement_range) << " | "
                << r.linear_fem_seconds << " |\n";
          if (r.linear_law.ran)
            law << "| " << r.c.name << " | " << fmt(100 * r.linear_law.force_error) << " / "
                << fmt(100 * r.linear_law.impulse_error) << " / "
                << percent(r.linear_law.displacement_error) << " | "
                << (r.linear_fem.ran ? percent(r.linear_fem.displacement_error)
                                     : std::string("(turning wall)"))
                << " |\n";
          const auto fid = [](const MethodResult &m) {
            return fmt(100 * m.force_error) + " / " + fmt(100 * m.impulse_error) + " / " +
                   percent(m.displacement_error);
          };
          if (r.corotational.ran)
            split << "| " << r.c.name << " | " << fid(r.linear_law) << " | " << fid(r.rotation)
                  << " | " << fid(r.corotational) << " | " << fmt(r.fem_ms_per_step) << " / "
                  << fmt(r.corotational_ms) << " / " << fmt(r.linear_law_ms) << " |\n";
        }
      v["corotational_table"] = split.str();
      v["open_loop_table"]  = open.str();
      v["linear_fem_table"] = lin.str();
      v["linear_law_table"] = law.str();
    }

    std::string
    sweep_table(const std::vector<SweepRow> &sweep)
    {
      std::ostringstream md;
      md.precision(3);
      for (const auto &w : sweep)
        md << "| " << w.c << " | " << w.method << " | " << w.k << (w.fem_equivalent ? " (FEM)" : "")
           << " | " << percent(w.result.force_error) << " | " << percent(w.result.impulse_error)
           << " | " << percent(w.result.displacement_error) << " | "
           << fmt(1e3 * w.result.max_penetration) << " | "
           << optional_count(w.result.contact_vertices_max) << " | "
           << (w.result.stable ? "yes" : "**no**") << " |\n";
      return md.str();
    }

    /// Per case, the stable method with the smallest of the larger of its impulse and
    /// displacement errors (each at its worst under the perturbations).
    std::string
    best_table(const std::vector<Row> &rows)
    {
      std::ostringstream md;
      for (const auto &r : rows)
        {
          size_t best     = 0;
          double best_err = 1e300;
          for (size_t m = 0; m < method_names.size(); ++m)
            {
              const MethodResult &x   = r.method[m];
              const double        err = std::max(worst(x.impulse_error, x.impulse_range),
                                                 worst(x.displacement_error, x.displacement_range));
              if (x.ran && x.stable && err < best_err)
                best = m, best_err = err;
            }
          const MethodResult &x = r.method[best];
          md << "| " << r.c.name << " | " << method_names[best] << " | "
             << figure(x.impulse_error, x.impulse_range) << " | "
             << figure(x.displacement_error, x.displacement_range) << " | "
             << figure(x.force_error, x.force_range) << " |\n";
        }
      return md.str();
    }

    std::string
    mapping_table(const std::vector<MappingRow> &mapping)
    {
      std::ostringstream md;
      md.precision(3);
      for (const auto &m : mapping)
        md << "| " << m.name << " | " << m.distinct_first_contacts << " | " << 1e3 * m.spread
           << " | " << m.feedthrough_ratio << " | " << m.static_ratio << " | "
           << percent(m.row->method[0].impulse_error) << " | "
           << percent(m.row->method[1].impulse_error) << " | "
           << percent(m.row->same_contact.impulse_error) << " | "
           << percent(m.row->method[0].displacement_error) << " | "
           << percent(m.row->method[1].displacement_error) << " | "
           << percent(m.row->same_contact.displacement_error) << " |\n";
      return md.str();
    }

    std::string
    plate_table(const PlateStudy &plate)
    {
      const auto cell = [&](const CouplingRun &r) { return coupling_cell(r, plate.rigid_peak); };
      std::ostringstream md;
      md.precision(3);
      for (size_t g = 0; g < plate.grid.size(); ++g)
        {
          const auto [k, b]  = plate.grid[g];
          const bool rigid   = k == 0 && b == 0;
          md << "| " << (rigid ? "rigid" : std::to_string(static_cast<int>(k))) << " | "
             << (rigid ? std::string("-") : std::to_string(b).substr(0, 3)) << " | "
             << cell(plate.runs[3 * g]) << " | " << cell(plate.runs[3 * g + 1]) << " | "
             << cell(plate.runs[3 * g + 2]) << " | " << plate.exactness[g] << " |\n";
        }
      return md.str();
    }

    std::string
    join(const std::vector<std::string> &items, const std::string &separator)
    {
      std::string out;
      for (const auto &item : items)
        out += (out.empty() ? "" : separator) + item;
      return out;
    }

    /// One line per reduced nonlinear model: its basis, cubature and file, and each case's
    /// Newton steps cut back or not converged.
    std::string
    reduced_prose(const PlaneStudy &s)
    {
      std::ostringstream md;
      for (size_t k = 0; k < s.models.reduced.size(); ++k)
        {
          const ReducedNonlinearModel &m = s.models.reduced[k];
          md << "- `" << s.models.reduced_names[k] << "`: a reduced nonlinear model (`"
             << m.path << "`: r = " << m.size << " from " << m.lowest_modes << " lowest modes, "
             << m.residual_modes << " residual modes and " << m.modal_derivatives
             << " modal derivatives, "
             << (m.every_element ? "every element" : std::to_string(m.cubature_elements.size()) +
                                                       " cubature elements")
             << "), the truth's penalty walls; Newton steps cut back / not converged:";
          for (const Row &r : s.rows)
            md << " " << r.c.name << " " << r.reduced_cut_failed[k][0] << " / "
               << r.reduced_cut_failed[k][1] << ";";
          md << "\n";
        }
      return md.str();
    }

    /// The figures the prose of planes.md names.
    TemplateValues
    prose_values(const PlaneStudy &s)
    {
      const auto &o = s.options;
      const auto &m = s.models;
      const double tau = s.body.time_step;
      double       penalty = 0;
      for (const auto &w : s.sweep)
        if (w.fem_equivalent)
          penalty = w.k / m.mean_vertex_area;
      const bool rigid = s.rows.empty() || s.rows[0].vertex_stiffness == 0;
      return {
        {"stamp", report_stamp()},
        {"scene", o.scene},
        {"fe_degree", std::to_string(s.body.fe_degree)},
        {"mesh", fs::path(s.body.mesh_file).filename().string()},
        {"quick", o.quick ? "1" : ""},
        {"chosen_cases", join(o.cases, ", ")},
        {"reduced", reduced_prose(s)},
        {"n_cases", std::to_string(s.rows.size())},
        {"n_orientations", std::to_string(m.vdof.n_orientations)},
        {"subdivisions", std::to_string(o.subdivisions)},
        {"vdof_length", std::to_string(m.vdof.length)},
        {"tau_ms", fmt(tau * 1e3)},
        {"tau_s", fmt(tau)},
        {"n_surface", std::to_string(m.vdof.n_surface)},
        {"seconds_per_orientation", fmt(m.seconds_per_orientation)},
        {"n_vertices", std::to_string(m.vertex.n_inputs / 3)},
        {"margin_mm", fmt(1e3 * o.margin)},
        {"vertex_stiffness", rigid ? "" : std::to_string(s.rows[0].vertex_stiffness)},
        {"stiffness_from_penalty", o.vertex_stiffness < 0 ? "1" : ""},
        {"n_modes", std::to_string(m.modal.n_modes)},
        {"surface_modes", std::to_string(m.modal.surface_modes)},
        {"direct_gb", fmt(m.vertex.bytes() / 1e9)},
        {"vertex_reused", m.vertex_reused ? "1" : ""},
        {"vertex_precompute_s", std::to_string(static_cast<int>(m.vertex_precompute_seconds))},
        {"side", vec_text(s.directions.side)},
        {"top", vec_text(s.directions.top)},
        {"oblique", vec_text(s.directions.oblique)},
        {"between", vec_text(s.directions.between)},
        {"penalty", fmt(penalty)},
        {"mean_vertex_area_mm2", fmt(m.mean_vertex_area * 1e6)},
        {"penalty_per_vertex", fmt(penalty * m.mean_vertex_area)},
        {"band_mm", fmt(1e3 * m.vdof.band)},
        {"rigid_peak", fmt(s.plate.rigid_peak)},
      };
    }
  } // namespace

  void
  write_plane_report(const std::string &dir, const PlaneStudy &s)
  {
    write_mapping_csv(dir, s.mapping);
    write_stiffness_csv(dir, s.sweep);
    write_planes_csv(dir, s.rows);
    write_cases_csv(dir, s.rows);
    write_forces_csv(dir, s.rows, s.body.time_step);
    write_coupling_csv(dir, s.plate);
    if (s.options.perturbations > 0)
      write_spread_csv(dir, s.rows, s.options.perturbations + 1);
    TemplateValues v = prose_values(s);
    v["methods_table"] = methods_table(s.rows);
    reference_tables(s.rows, v);
    v["sweep_table"]   = sweep_table(s.sweep);
    v["sweep"]         = s.sweep.empty() ? "" : "1";
    v["best_table"]    = best_table(s.rows);
    v["perturbations"] = s.options.perturbations > 0 ? std::to_string(s.options.perturbations) : "";
    v["corotational"]  = s.options.corotational ? "1" : "";
    v["converged_table"] = converged_results(dir, s.rows);
    v["converged"]       = v["converged_table"].empty() ? "" : "1";
    v["converged_degree"] = std::to_string(s.options.converged_degree);
    v["converged_truth"]  = converged_truth_name(s.options);
    v["same_mesh"]        = s.options.converged_mesh.empty() ? "1" : "";
    v["converged_mesh"]   = s.options.converged_mesh;
    double gap = 0;
    for (const Row &r : s.rows)
      gap = std::max(gap, r.converged_surface_gap);
    v["surface_gap_mm"] = fmt(1e3 * gap);
    v["spread_table"]  = spread_table(s.rows);
    v["mapping_table"] = mapping_table(s.mapping);
    v["plate_table"]   = plate_table(s.plate);
    write_text_file((fs::path(dir) / "planes.md").string(),
                    fill_template(read_template("validation/templates/planes.md"), v));
  }
} // namespace irdm::validation::planes
