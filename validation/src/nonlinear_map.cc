// The nonlinear map's runs (nonlinear_map.h): the plane study's runner on the map's load sweeps
// of the grounded cat, and the free-body study's on the free cat's impacts and drops; each run
// becomes one row per method and truth.
#include "nonlinear_map.h"
#include "free_body_runs.h"
#include "plane_runs.h"

#include <irdm_common/error.h>
#include <reference_fem/scene.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <map>
#include <set>

namespace fs = std::filesystem;

namespace irdm::validation::nonlinear
{
  namespace
  {
    /// The bar wave speed sqrt(E / rho) (m/s): an impact's speed over it is its dimensionless
    /// size.
    double
    wave_speed(const double E, const double density)
    {
      return std::sqrt(E / density);
    }

    /// The body's extent along d (m): a press's depth over it is its nominal strain.
    double
    extent(const VirtualDofModel &model, const planes::Vec3 &d)
    {
      double lo = INFINITY, hi = -INFINITY;
      for (const auto &x : model.coordinates)
        lo = std::min(lo, planes::dot(d, x)), hi = std::max(hi, planes::dot(d, x));
      return hi - lo;
    }

    /// A plane method's rows: against the P1 truth, and against the converged truth (named)
    /// where it ran.
    void
    add_plane_rows(std::vector<MapRow> &rows, const MapRow &base, const planes::MethodResult &m,
                   const double us_per_step, const std::string &converged)
    {
      if (!m.ran)
        return;
      MapRow r             = base;
      r.us_per_step        = us_per_step;
      r.stable             = m.stable;
      r.truth              = p1_truth;
      r.force_error        = m.force_error;
      r.impulse_error      = m.impulse_error;
      r.displacement_error = m.displacement_error;
      rows.push_back(r);
      if (converged.empty() || m.converged_force_error < 0)
        return;
      r.truth              = converged;
      r.force_error        = m.converged_force_error;
      r.impulse_error      = m.converged_impulse_error;
      r.displacement_error = m.converged_displacement_error;
      rows.push_back(r);
    }

    /// One plane case's rows: every runtime method and every FEM law beside the truth, and the
    /// P1 truth against the converged truth where that ran.
    void
    plane_rows(std::vector<MapRow> &rows, const planes::Row &pr, const std::string &material,
               const double load)
    {
      const unsigned N = static_cast<unsigned>(pr.F_fem.size() - 1);
      MapRow         base;
      base.c = pr.c.name, base.material = material, base.family = pr.c.kind, base.load = load;
      base.largest_strain  = pr.largest_strain;
      base.fem_ms_per_step = pr.fem_ms_per_step;
      const std::string converged = pr.truth_force_error >= 0 ? pr.converged_truth : "";
      for (size_t k = 0; k < planes::method_names.size(); ++k)
        {
          base.method = planes::method_names[k];
          add_plane_rows(rows, base, pr.method[k], pr.method[k].force_us + pr.method[k].surface_us, converged);
        }
      for (const auto &[name, m] : pr.reduced)
        {
          base.method = name;
          add_plane_rows(rows, base, m, m.force_us + m.surface_us, converged);
        }
      base.method = "fem_linear_vertex_contact";
      add_plane_rows(rows, base, pr.linear_fem, 1e6 * pr.linear_fem_seconds / N, converged);
      base.method = "fem_small_strain";
      add_plane_rows(rows, base, pr.linear_law, 1e3 * pr.linear_law_ms, converged);
      base.method = "fem_corotational";
      add_plane_rows(rows, base, pr.corotational, 1e3 * pr.corotational_ms, converged);
      if (!converged.empty())
        {
          MapRow t             = base;
          t.method             = p1_truth;
          t.truth              = converged;
          t.us_per_step        = 1e3 * pr.fem_ms_per_step;
          t.force_error        = pr.truth_force_error;
          t.impulse_error      = pr.truth_impulse_error;
          t.displacement_error = pr.truth_displacement_error;
          rows.push_back(t);
        }
    }

    /// The free study's row key: case and Young's modulus.
    using CaseKey = std::pair<std::string, double>;

    /// The --reduced-model files of a free body (rigid modes in the basis) or of the
    /// grounded one.
    std::vector<std::string>
    reduced_models_of(const std::vector<std::string> &files, const bool free_body)
    {
      std::vector<std::string> out;
      for (const std::string &file : files)
        if ((load_reduced_nonlinear_model(file).rigid_modes > 0) == free_body)
          out.push_back(file);
      return out;
    }
  } // namespace

  bool
  in_planes(const std::string &family)
  {
    return family.rfind("free_", 0) != 0;
  }

  std::vector<MapRow>
  rows_kept(const std::vector<MapRow> &earlier, const std::vector<MapRow> &made,
            const std::vector<std::string> &families, const bool keep_rows)
  {
    std::set<std::pair<std::string, std::string>> ran; // case, material
    for (const MapRow &r : made)
      ran.insert({r.c, r.material});
    std::vector<MapRow> kept;
    for (const MapRow &r : earlier)
      {
        const std::string family = in_planes(r.family) ? "planes" : "free";
        const bool family_ran = std::find(families.begin(), families.end(), family) != families.end();
        if (!family_ran || (keep_rows && ran.count({r.c, r.material}) == 0))
          kept.push_back(r);
      }
    return kept;
  }

  std::vector<MapRow>
  run_plane_family(const NonlinearMapOptions &o, std::ostream &log)
  {
    using namespace planes;
    PlaneValidationOptions po = o.planes;
    po.reduced_models         = reduced_models_of(o.planes.reduced_models, false);
    po.perturbations          = 0;
    po.sweep_cases.clear();
    po.corotational = true;
    const fem::Scene body = planes::grounded_body(po.scene);
    // The case names are known before any model is made: a wrong converged case is refused
    // before hours of work.
    const std::vector<Case> names = load_sweep(Directions{}, o.press_directions, o.press_depths, o.impact_speeds);
    for (const std::string &name : po.converged_cases)
      if (std::none_of(names.begin(), names.end(), [&](const Case &c) { return c.name == name; }))
        throw InputError("validate-nonlinear: --converged-cases names '" + name +
                         "', which is not a case of the plane sweeps");
    const PlaneModels     models = prepare_models(body, po, log);
    const Directions      dirs   = case_directions(models.vdof);
    const std::string     material = free_body::material_name(body.youngs_modulus);
    const double          c_wave   = wave_speed(body.youngs_modulus, body.density);
    std::vector<unsigned> fem_order;
    std::vector<MapRow>   rows;
    for (const Case &c : load_sweep(dirs, o.press_directions, o.press_depths, o.impact_speeds))
      {
        const Row    pr   = run_case(c, body, models, po, fem_order, log).row;
        const double load = c.speed > 0 ? c.speed / c_wave : c.depth / extent(models.vdof, c.d[0]);
        plane_rows(rows, pr, material, load);
      }
    return rows;
  }

  FreeBodyValidationOptions
  free_family_options(const NonlinearMapOptions &o)
  {
    using namespace free_body;
    FreeBodyValidationOptions fo = o.free;
    fo.reduced_models            = reduced_models_of(o.planes.reduced_models, true);
    fo.only_cases                = o.drops;
    fo.only_cases.push_back("impact");
    fo.impact_speeds     = o.free_impact_speeds;
    fo.stability_seconds = 0;
    fo.sensitivity = fo.truth_check = false;
    fo.small_strain = fo.corotational = true;
    for (const std::string &name : fo.converged_cases)
      {
        const auto chosen = chosen_cases(fo);
        if (std::none_of(chosen.begin(), chosen.end(), [&](const Case &k) { return k.name == name; }))
          throw InputError("validate-nonlinear: --free-converged-cases names '" + name +
                           "', which is not a case of the free sweeps");
      }
    read_base_scene(fo, "validate-nonlinear"); // the scene and the options' agreement
    return fo;
  }

  std::vector<MapRow>
  run_free_family(const NonlinearMapOptions &o, std::ostream &log)
  {
    using namespace free_body;
    const FreeBodyValidationOptions fo   = free_family_options(o);
    const BaseScene                 base = read_base_scene(fo, "validate-nonlinear");
    fs::create_directories(fo.model_dir);
    FreeStudy study;
    run_materials(fo, base.text, study, log);
    // Each case's speed at first contact, its largest strain, and each method's cost.
    std::map<std::string, double> speed;
    for (const Case &k : chosen_cases(fo))
      speed[k.name] = k.in_study() ? k.impact_speed : std::sqrt(2 * 9.81 * k.height);
    // Per case: the truth's largest strain over the first contact and its cost per step; per
    // case and method, the method's own cost per step (the runtime's, or an FEM law's).
    std::map<CaseKey, double> strain, truth_ms;
    std::map<std::tuple<std::string, double, std::string>, double> cost;
    std::map<std::tuple<std::string, double, std::string>, bool>   stable;
    for (const StrainRow &s : study.strain)
      strain[{s.c, s.E}] = s.first_largest;
    for (const Row &r : study.rows)
      truth_ms[{r.c, r.E}] = r.fem_ms, cost[{r.c, r.E, r.method}] = r.irdm_us,
                      stable[{r.c, r.E, r.method}] = r.stable;
    for (const LinearizationRow &l : study.linearization)
      if (l.fem_ms > 0)
        cost[{l.c, l.E, l.method}] = 1e3 * l.fem_ms;
    const auto row_of = [&](const std::string &c, const double E, const std::string &method,
                            const char *truth, const double force, const double impulse,
                            const double deformation) {
      MapRow b;
      b.c = c, b.material = material_name(E), b.truth = truth;
      b.method = method == "fem_neo_hookean" ? p1_truth : method;
      b.family = c.rfind("impact_", 0) == 0 ? "free_impact" : "free_drop";
      b.load   = speed.at(c) / wave_speed(E, base.scene.density);
      b.largest_strain  = strain.count({c, E}) ? strain.at({c, E}) : NAN;
      b.fem_ms_per_step = truth_ms.count({c, E}) ? truth_ms.at({c, E}) : NAN;
      b.us_per_step = method == "fem_neo_hookean" ? 1e3 * b.fem_ms_per_step
                      : cost.count({c, E, method}) ? cost.at({c, E, method})
                                                   : NAN;
      b.force_error = force, b.impulse_error = impulse, b.deformation_error = deformation;
      b.stable = stable.count({c, E, method}) == 0 || stable.at({c, E, method});
      return b;
    };
    std::vector<MapRow> rows;
    for (const Row &r : study.rows)
      if (r.fem_failed.empty()) // no truth, no error to map (the log says why)
        rows.push_back(row_of(r.c, r.E, r.method, p1_truth, r.first_force_error,
                              r.first_impulse_error, r.first_deformation_error));
    // The FEM laws against the P1 truth, and every run against the converged truth where it
    // ran (the P1 truth among them); not the runs against the linear FEM or the corotational
    // one.
    const std::string converged = free_body::converged_truth_name(fo);
    for (const LinearizationRow &l : study.linearization)
      if ((l.reference == "fem_neo_hookean" && l.method.rfind("fem_", 0) == 0 &&
           l.method != converged) ||
          l.reference == converged)
        {
          const RunErrors &e  = l.errors;
          const double     no = l.failed.empty() ? 1 : NAN; // a failed run has no error
          rows.push_back(row_of(l.c, l.E, l.method, l.reference == converged ? converged.c_str() : p1_truth,
                                no * e.window_force, no * e.window_impulse,
                                no * e.window_deformation));
          rows.back().stable = rows.back().stable && l.failed.empty();
        }
    return rows;
  }
} // namespace irdm::validation::nonlinear
