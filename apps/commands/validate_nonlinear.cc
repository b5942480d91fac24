// irdm validate-nonlinear: where each method holds, against the size of the load.
#include "../command.h"

#include <irdm_common/files.h>
#include <validation/nonlinear_validation.h>

#include <algorithm>
#include <iostream>
#include <memory>
#include <sstream>
#include <string>

namespace irdm::cli
{
  namespace
  {
    /// A list option that "none" empties (CLI11 keeps a vector's default when the option comes
    /// with no value).
    template <class T>
    CLI::Option *
    list_or_none(CLI::App &app, const std::string &name, std::vector<T> &v, const std::string &help)
    {
      std::ostringstream d;
      for (const T &x : v)
        d << (d.tellp() > 0 ? " " : "") << x;
      return app
        .add_option_function<std::vector<std::string>>(
          name,
          [&v, name](const std::vector<std::string> &given) {
            v.clear();
            if (given.size() == 1 && given[0] == "none")
              return;
            if (std::find(given.begin(), given.end(), "none") != given.end())
              throw CLI::ValidationError(name, "none stands alone");
            for (const std::string &x : given)
              {
                T value{};
                if (!CLI::detail::lexical_cast(x, value))
                  throw CLI::ValidationError(name, "'" + x + "' is not a value of this list");
                v.push_back(value);
              }
          },
          help + " (default: " + d.str() + "; none: an empty list)")
        ->type_size(1)
        ->expected(1, -1);
    }

    /// The grounded cat's sweeps and models (the plane study's).
    void
    add_plane_options(CLI::App &app, irdm::validation::NonlinearMapOptions &o)
    {
      auto &p = o.planes;
      app.add_option("--scene", p.scene, "the grounded body (its probes are ignored)")
        ->capture_default_str()
        ->check(CLI::ExistingFile);
      app.add_option("--model", p.model_file, "virtual-DOF model (reused if made from this scene and spec)")
        ->capture_default_str();
      app.add_option("--subdivisions", p.subdivisions, "dome subdivisions of the virtual-DOF model")
        ->capture_default_str()
        ->check(CLI::Range(0u, 4u));
      app.add_option("--length", p.length, "samples per response (the longest case is 0.6 s)")
        ->capture_default_str()
        ->check(CLI::Range(1u, 100000u));
      app.add_option("--vertex-model", p.vertex_model_file,
                     "many-vertex contact model (every free surface vertex; reused if made from this scene)")
        ->capture_default_str();
      app.add_flag("!--no-direct", p.direct, "skip vertex_contact_direct (its H needs GBs of memory)");
      app.add_option("--reduced-model", p.reduced_models,
                     "reduced nonlinear models (irdm precompute --reduced), each a method "
                     "reduced_<file stem>: a grounded body's on every grounded case, a free "
                     "body's on the free cases of its material")
        ->check(CLI::ExistingFile);
      list_or_none(app, "--press-directions", o.press_directions, "the presses' directions")
        ->check(CLI::IsMember({"top", "side", "between", "oblique", "none"}));
      list_or_none(app, "--press-depths", o.press_depths, "m; each press direction at each depth")
        ->check(CLI::Range(1e-5, 0.05) | CLI::IsMember({"none"}));
      list_or_none(app, "--impact-speeds", o.impact_speeds, "m/s; the side impacts (2 mm deep)")
        ->check(CLI::Range(1e-3, 10.0) | CLI::IsMember({"none"}));
      list_or_none(app, "--converged-cases", p.converged_cases,
                   "grounded cases also run by the converged truth (case names as in "
                   "nonlinear.csv, for example press_side_5mm); their rows are against it");
      app.add_option("--converged-mesh", p.converged_mesh,
                     "the converged truth on this finer gmsh mesh of the body (for example "
                     "meshes/cat_fine.msh; each wall's depth from its own outermost point) in "
                     "place of P2 on the scene's mesh")
        ->check(CLI::ExistingFile);
      app.add_option("--converged-degree", p.converged_degree,
                     "the converged truth's element degree (default: 2 on the scene's mesh, 1 "
                     "with --converged-mesh)")
        ->check(CLI::IsMember({1u, 2u}));
    }

    /// The free cat's sweeps and models (the free-body study's).
    void
    add_free_options(CLI::App &app, irdm::validation::NonlinearMapOptions &o)
    {
      auto &f = o.free;
      app.add_option("--free-scene", f.scene, "the free body (fixed to nothing)")
        ->capture_default_str()
        ->check(CLI::ExistingFile);
      app.add_option("--free-models", f.model_dir, "folder of the free-body models (reused when of this scene and spec)")
        ->capture_default_str();
      app.add_option("--materials", f.materials, "Pa; Young's moduli of the free cat")
        ->capture_default_str()
        ->check(CLI::Range(1.0, 1e12));
      app.add_option("--fem-divisions", f.fem_divisions,
                     "the free truth runs at tau / M: one M for every material or one per material")
        ->capture_default_str()
        ->check(CLI::Range(1u, 64u));
      list_or_none(app, "--free-impact-speeds", o.free_impact_speeds,
                   "m/s; the free cat onto the floor, gravity off")
        ->check(CLI::Range(1e-3, 10.0) | CLI::IsMember({"none"}));
      list_or_none(app, "--drops", o.drops, "the drops (gravity on)")
        ->check(CLI::IsMember({"drop_2cm", "drop_5cm", "drop_10cm", "none"}));
      list_or_none(app, "--free-converged-cases", f.converged_cases,
                   "free cases also run by the converged truth (drop_2cm, impact_0.2, ...): P2 on "
                   "the same mesh, or P1 on --free-converged-mesh");
      app.add_option("--free-converged-mesh", f.converged_mesh,
                     "a finer gmsh mesh of the free body for that truth (irdm validate-free "
                     "--converged-mesh)")
        ->check(CLI::ExistingFile);
      app.add_option("--vdof-subdivisions", f.vdof_subdivisions,
                     "the free cat's virtual DOFs (icosahedron subdivisions; -1: not run)")
        ->capture_default_str()
        ->check(CLI::Range(-1, 3));
      app.add_flag("--reuse-vdof", f.reuse_models, "take a free virtual-DOF model already in --free-models");
      app.add_option("--force-modes", f.force_modes,
                     "each free route also with this many modes in the force loop (0: not run)")
        ->capture_default_str();
    }
  } // namespace

  Command
  add_validate_nonlinear(CLI::App &app)
  {
    auto o   = std::make_shared<irdm::validation::NonlinearMapOptions>();
    auto *vn = app.add_subcommand("validate-nonlinear", "where each method holds: every method's error against the size of the load, against the nonlinear truth; reports/nonlinear");
    vn->footer("Runs the grounded cat's load sweeps (presses along --press-directions at each of "
      "--press-depths, side impacts at each of --impact-speeds) through the plane study's runner "
      "(irdm validate-planes: virtual DOFs, many-vertex contact modal and direct, the linear FEM, "
      "the small-strain and corotational FEM laws, against the neo-Hookean truth), and the free "
      "cat's (impacts at --free-impact-speeds, --drops, each of --materials) through the free "
      "study's (irdm validate-free: both routes, virtual DOFs, the body-frame linear and the "
      "corotational FEM). Rows are against the converged truth on --converged-cases (P2 on the "
      "scene's mesh, or --converged-mesh), the P1 truth elsewhere (column truth). --families runs one family and keeps the other's rows from the "
      "last run in DIR/nonlinear (with --keep-rows also its own family's rows of the cases and materials it does "
      "not run); --families none redraws the report from them. Writes "
      "DIR/nonlinear/nonlinear.csv (case,material,method,force_error,impulse_error,"
      "displacement_error,deformation_error,largest_strain,us_per_step,fem_ms_per_step,stable,"
      "family,load,truth), against_p1.csv, limits.csv, nonlinear.md, map.png, map_force.png, "
      "speed_accuracy.png. Models are made first or reused (an existing file of another kind or "
      "spec is refused, never overwritten). A full run takes hours: the P2 truth costs about a "
      "second per step on the cat.");
    vn->add_option("--out", o->report_dir, "report folder")->capture_default_str();
    list_or_none(*vn, "--families", o->families, "the families run (none: the report again from the CSV)")
      ->check(CLI::IsMember({"planes", "free", "none"}));
    vn->add_flag("--keep-rows", o->keep_rows,
                 "replace only the rows of the cases and materials this run makes, and keep the earlier run's "
                 "others of its families too (to add a method or a case to part of the map)");
    add_plane_options(*vn, *o);
    add_free_options(*vn, *o);
    return {vn, [o, vn] {
              irdm::check_output_folder("--out", o->report_dir);
              if (!o->planes.converged_mesh.empty() && vn->count("--converged-degree") == 0)
                o->planes.converged_degree = 1;
              if (!o->free.converged_mesh.empty()) // a finer mesh's truth is P1 (P2 on it: days)
                o->free.converged_degree = 1;
              o->plot_script = std::string(IRDM_SOURCE_DIR) + "/validation/plot_nonlinear.py";
              o->command     = invocation();
              irdm::validation::run_nonlinear_validation(*o, std::cout);
              return 0;
            }};
  }
} // namespace irdm::cli
