// The nonlinear map's files (nonlinear_map.h): nonlinear.csv and against_p1.csv, the limits
// where each method passes 5 % and 10 % (limits.csv), and nonlinear.md from
// validation/templates/nonlinear.md.
#include "nonlinear_map.h"

#include <irdm_common/error.h>
#include <irdm_common/files.h>
#include <irdm_common/format.h>
#include <irdm_common/report_stamp.h>
#include <irdm_common/report_template.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <tuple>

namespace fs = std::filesystem;

namespace irdm::validation::nonlinear
{
  namespace
  {
    /// A figure as the CSV holds it: empty when it was not measured.
    std::string
    cell(const double x)
    {
      if (std::isnan(x))
        return "";
      std::ostringstream s;
      s.precision(6);
      s << x;
      return s.str();
    }

    double
    number(const std::string &s, const std::string &file)
    {
      if (s.empty())
        return NAN;
      try
        {
          size_t       used = 0;
          const double x    = std::stod(s, &used);
          if (used == s.size())
            return x;
        }
      catch (const std::exception &)
        {}
      throw InputError("'" + file + "': '" + s + "' is not a number");
    }

    std::string
    percent(const double x)
    {
      return std::isnan(x) ? "" : fmt(100 * x) + " %";
    }

    /// A limit as limits.csv and the report give it: the load, "<first" when the sweep's first
    /// point is already past, ">last" when none is.
    std::string
    limit_text(const double x, const bool below, const bool beyond, const double first,
               const double last)
    {
      return below ? "<" + fmt(first) : beyond ? ">" + fmt(last) : fmt(x);
    }

    using Key = std::tuple<std::string, std::string, std::string>; // family, material, method

    /// Each family and material's methods, in the order the rows hold them.
    std::vector<Key>
    keys_of(const std::vector<MapRow> &rows, const std::string &truth)
    {
      std::vector<Key> keys;
      for (const MapRow &r : rows)
        if (r.truth == truth)
          {
            const Key k{r.family, r.material, r.method};
            if (std::find(keys.begin(), keys.end(), k) == keys.end())
              keys.push_back(k);
          }
      return keys;
    }

    /// The limits table: per family and material, each method's 5 % and 10 % loads of the shape
    /// error and the force error.
    std::string
    limits_table(const std::vector<Limit> &limits)
    {
      std::map<std::tuple<std::string, std::string, std::string, std::string>, const Limit *> at;
      for (const Limit &l : limits)
        at[{l.family, l.material, l.method, l.measure}] = &l;
      std::ostringstream md;
      md << "| family | material | method | truth | points | load range | shape 5 % | shape 10 % | "
            "force 5 % | force 10 % |\n|---|---|---|---|---|---|---|---|---|---|\n";
      for (const Limit &l : limits)
        {
          if (l.measure != "shape")
            continue;
          const Limit *f = at.at({l.family, l.material, l.method, "force"});
          md << "| " << l.family << " | " << l.material << " | " << l.method << " | " << l.truth
             << " | " << l.points << " | " << fmt(l.first_load) << " to " << fmt(l.last_load)
             << " | " << limit_text(l.limit5, l.below5, l.beyond5, l.first_load, l.last_load)
             << " | " << limit_text(l.limit10, l.below10, l.beyond10, l.first_load, l.last_load)
             << " | " << limit_text(f->limit5, f->below5, f->beyond5, f->first_load, f->last_load)
             << " | " << limit_text(f->limit10, f->below10, f->beyond10, f->first_load, f->last_load)
             << " |\n";
        }
      return md.str();
    }

    /// The P1 truth against each other truth, case by case, where both ran.
    std::string
    truth_table(const std::vector<MapRow> &rows)
    {
      std::ostringstream md;
      md << "| case | material | against | force | impulse | shape | P1 largest strain |\n"
            "|---|---|---|---|---|---|---|\n";
      bool any = false;
      for (const MapRow &r : rows)
        if (r.method == p1_truth && r.truth != p1_truth)
          {
            any = true;
            md << "| " << r.c << " | " << r.material << " | " << r.truth << " | "
               << percent(r.force_error) << " | " << percent(r.impulse_error) << " | "
               << percent(r.shape_error()) << " | " << fmt(r.largest_strain) << " |\n";
          }
      return any ? md.str() : "";
    }

    /// The corotational law's share of the linear law's miss, case by case (P1 truth): the
    /// strain's share is the corotational law's own error, the rest the rotation's.
    std::string
    share_table(const std::vector<MapRow> &rows)
    {
      std::map<std::pair<std::string, std::string>, std::pair<const MapRow *, const MapRow *>> at;
      for (const MapRow &r : rows)
        if (r.truth == p1_truth)
          {
            if (r.method == "fem_small_strain" || r.method == "fem_linear_body_frame")
              at[{r.material, r.c}].first = &r;
            if (r.method == "fem_corotational")
              at[{r.material, r.c}].second = &r;
          }
      std::ostringstream md;
      md << "| case | material | load | linear law, shape | corotational, shape | corotational / linear | "
            "linear law, force | corotational, force |\n|---|---|---|---|---|---|---|---|\n";
      for (const MapRow &r : rows)
        if (r.truth == p1_truth && r.method == "fem_corotational")
          {
            const auto &[lin, cor] = at.at({r.material, r.c});
            if (!lin)
              continue;
            md << "| " << r.c << " | " << r.material << " | " << fmt(r.load) << " | "
               << percent(lin->shape_error()) << " | " << percent(cor->shape_error()) << " | "
               << percent(cor->shape_error() / lin->shape_error()) << " | "
               << percent(lin->force_error) << " | " << percent(cor->force_error) << " |\n";
          }
      return md.str();
    }

    void
    write_limits_csv(const std::string &file, const std::vector<Limit> &limits)
    {
      std::ostringstream csv;
      csv << "family,material,method,truth,measure,points,first_load,last_load,limit_5pct,"
             "limit_10pct\n";
      for (const Limit &l : limits)
        csv << l.family << ',' << l.material << ',' << l.method << ',' << l.truth << ','
            << l.measure << ',' << l.points << ',' << cell(l.first_load) << ','
            << cell(l.last_load) << ','
            << limit_text(l.limit5, l.below5, l.beyond5, l.first_load, l.last_load) << ','
            << limit_text(l.limit10, l.below10, l.beyond10, l.first_load, l.last_load) << '\n';
      write_text_file(file, csv.str());
    }
  } // namespace

  double
  passing_load(const std::vector<std::pair<double, double>> &points, const double threshold,
               bool &below, bool &beyond)
  {
    below = beyond = false;
    for (size_t i = 0; i < points.size(); ++i)
      if (!(points[i].second <= threshold)) // NaN (not measured, or a failed run) passes too
        {
          if (i == 0)
            {
              below = true;
              return NAN;
            }
          const auto [x0, e0] = points[i - 1];
          const auto [x1, e1] = points[i];
          if (!std::isfinite(e1))
            return x1;
          const double a = (threshold - e0) / (e1 - e0);
          return std::exp(std::log(x0) + a * (std::log(x1) - std::log(x0)));
        }
    beyond = true;
    return NAN;
  }

  std::vector<Limit>
  limits(const std::vector<MapRow> &rows, const std::string &truth)
  {
    // A family and material is mapped against a truth only where every point is against it.
    std::map<std::pair<std::string, std::string>, std::set<std::string>> cases, against;
    for (const MapRow &r : rows)
      {
        cases[{r.family, r.material}].insert(r.c);
        if (r.truth == truth)
          against[{r.family, r.material}].insert(r.c);
      }
    std::vector<Limit> out;
    for (const auto &[family, material, method] : keys_of(rows, truth))
      {
        if (against[{family, material}] != cases[{family, material}])
          continue;
        std::vector<const MapRow *> line;
        for (const MapRow &r : rows)
          if (r.truth == truth && r.family == family && r.material == material && r.method == method)
            line.push_back(&r);
        std::sort(line.begin(), line.end(), [](const MapRow *a, const MapRow *b) { return a->load < b->load; });
        for (const char *measure : {"shape", "force", "impulse"})
          {
            Limit l{family, material, method, truth, measure};
            l.points     = static_cast<unsigned>(line.size());
            l.first_load = line.front()->load, l.last_load = line.back()->load;
            std::vector<std::pair<double, double>> points;
            for (const MapRow *r : line)
              {
                const double e = std::string(measure) == "shape" ? r->shape_error()
                                 : std::string(measure) == "force" ? r->force_error
                                                                   : r->impulse_error;
                points.push_back({r->load, r->stable ? e : NAN});
              }
            l.limit5  = passing_load(points, 0.05, l.below5, l.beyond5);
            l.limit10 = passing_load(points, 0.10, l.below10, l.beyond10);
            out.push_back(l);
          }
      }
    return out;
  }

  std::string
  csv_header()
  {
    return "case,material,method,force_error,impulse_error,displacement_error,deformation_error,"
           "largest_strain,us_per_step,fem_ms_per_step,stable,family,load,truth";
  }

  std::string
  csv_line(const MapRow &r)
  {
    std::ostringstream s;
    s << r.c << ',' << r.material << ',' << r.method << ',' << cell(r.force_error) << ','
      << cell(r.impulse_error) << ',' << cell(r.displacement_error) << ','
      << cell(r.deformation_error) << ',' << cell(r.largest_strain) << ','
      << cell(r.us_per_step) << ',' << cell(r.fem_ms_per_step) << ',' << (r.stable ? 1 : 0)
      << ',' << r.family << ',' << cell(r.load) << ',' << r.truth;
    return s.str();
  }

  std::vector<MapRow>
  read_rows(const std::string &file)
  {
    std::ifstream in(file);
    if (!in)
      throw IoError("cannot read '" + file + "'");
    std::string line;
    if (!std::getline(in, line) || line != csv_header())
      throw InputError("'" + file + "' is not a nonlinear map's CSV (its header differs)");
    std::vector<MapRow> rows;
    while (std::getline(in, line))
      {
        std::vector<std::string> f;
        std::stringstream        s(line);
        for (std::string x; std::getline(s, x, ',');)
          f.push_back(x);
        if (!line.empty() && line.back() == ',')
          f.push_back("");
        if (f.size() != 14)
          throw InputError("'" + file + "': a line has " + std::to_string(f.size()) +
                           " fields, not 14: " + line);
        MapRow r;
        r.c = f[0], r.material = f[1], r.method = f[2];
        r.force_error = number(f[3], file), r.impulse_error = number(f[4], file);
        r.displacement_error = number(f[5], file), r.deformation_error = number(f[6], file);
        r.largest_strain = number(f[7], file), r.us_per_step = number(f[8], file);
        r.fem_ms_per_step = number(f[9], file), r.stable = f[10] == "1";
        r.family = f[11], r.load = number(f[12], file), r.truth = f[13];
        rows.push_back(r);
      }
    return rows;
  }

  namespace
  {
    /// Each case and material's best truth: a finer mesh's over the same mesh's higher degree
    /// (which refines the elements, not the faceted body) over the P1 truth.
    std::map<std::pair<std::string, std::string>, std::string>
    best_truths(const std::vector<MapRow> &rows)
    {
      std::map<std::pair<std::string, std::string>, std::string> best;
      for (const MapRow &r : rows)
        {
          auto &b = best[{r.c, r.material}];
          if (b.empty() || truth_rank(r.truth) > truth_rank(b))
            b = r.truth;
        }
      return best;
    }

    /// The cases (and materials) a truth other than the P1 truth ran on.
    unsigned
    converged_cases(const std::vector<MapRow> &rows)
    {
      unsigned n = 0;
      for (const auto &[key, truth] : best_truths(rows))
        n += truth != p1_truth;
      return n;
    }

    /// nonlinear.csv's rows: each case against its best truth.
    std::vector<MapRow>
    best_rows(const std::vector<MapRow> &rows)
    {
      const auto          best = best_truths(rows);
      std::vector<MapRow> out;
      for (const MapRow &r : rows)
        if (r.truth == best.at({r.c, r.material}))
          out.push_back(r);
      return out;
    }

    /// The limits against every truth (where it covers a family), best truth first.
    std::vector<Limit>
    all_limits(const std::vector<MapRow> &rows)
    {
      std::vector<std::string> truths;
      for (const MapRow &r : rows)
        if (std::find(truths.begin(), truths.end(), r.truth) == truths.end())
          truths.push_back(r.truth);
      std::stable_sort(truths.begin(), truths.end(), [](const std::string &a, const std::string &b) {
        return truth_rank(a) > truth_rank(b);
      });
      std::vector<Limit> all;
      for (const std::string &t : truths)
        {
          const std::vector<Limit> l = limits(rows, t);
          all.insert(all.end(), l.begin(), l.end());
        }
      return all;
    }
  } // namespace

  int
  truth_rank(const std::string &truth)
  {
    if (truth == p1_truth)
      return 0;
    const std::string same_mesh = "fem_neo_hookean_p";
    const bool        degree_only =
      truth.rfind(same_mesh, 0) == 0 && truth.size() > same_mesh.size() &&
      truth.find('_', same_mesh.size()) == std::string::npos;
    return degree_only ? 1 : 2;
  }

  void
  write_csvs(const std::string &dir, const std::vector<MapRow> &rows)
  {
    std::ostringstream best, p1;
    best << csv_header() << '\n';
    p1 << csv_header() << '\n';
    for (const MapRow &r : best_rows(rows))
      best << csv_line(r) << '\n';
    for (const MapRow &r : rows)
      if (r.truth == p1_truth)
        p1 << csv_line(r) << '\n';
    write_text_file((fs::path(dir) / "nonlinear.csv").string(), best.str());
    write_text_file((fs::path(dir) / "against_p1.csv").string(), p1.str());
    write_limits_csv((fs::path(dir) / "limits.csv").string(), all_limits(rows));
  }

  void
  write_markdown(const std::string &dir, const NonlinearMapOptions &o, const std::vector<MapRow> &rows,
                 const std::map<std::string, std::string> &commands)
  {
    std::ostringstream runs;
    for (const auto &[family, command] : commands)
      runs << "- " << family << ": `" << command << "`\n";
    TemplateValues v{{"stamp", report_stamp()},
                     {"plane_scene", o.planes.scene},
                     {"free_scene", o.free.scene},
                     {"n_rows", std::to_string(best_rows(rows).size())},
                     {"n_converged", std::to_string(converged_cases(rows))},
                     {"limits_table", limits_table(all_limits(rows))},
                     {"truth_table", truth_table(rows)},
                     {"commands", runs.str()},
                     {"share_table", share_table(rows)},
                     {"map_chart", fs::exists(fs::path(dir) / "map.png") ? "1" : ""},
                     {"p1_chart", fs::exists(fs::path(dir) / "map_p1.png") ? "1" : ""},
                     {"speed_chart", fs::exists(fs::path(dir) / "speed_accuracy.png") ? "1" : ""}};
    write_text_file((fs::path(dir) / "nonlinear.md").string(),
                    fill_template(read_template("validation/templates/nonlinear.md"), v));
  }
} // namespace irdm::validation::nonlinear
