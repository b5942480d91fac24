// The free body against the nonlinear FEM (validation/free_body_validation.h): the cases
// (free_body_cases.cc), each material's models and cases through the truth and every method
// (free_body_runs.cc, free_body_stability.cc), and the report (free_body_report.cc).
#include <irdm_common/error.h>
#include <irdm_common/files.h>
#include <reference_fem/mesh.h>
#include <reference_fem/scene.h>
#include <validation/free_body_validation.h>

#include "free_body_runs.h"

#include "surface_transfer.h"

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

namespace fs = std::filesystem;

namespace irdm::validation
{
  namespace free_body
  {
    namespace
    {
      void
      check_options(const FreeBodyValidationOptions &o, const fem::Scene &base, const std::string &command)
      {
        if (!base.fixed_surfaces.empty())
          throw InputError(command + ": the scene '" + o.scene + "' fixes a surface; the "
                           "free-body validation needs a body fixed to nothing");
        if (!(o.duration > 0))
          throw InputError(command + ": the duration must be positive");
        if (o.fem_divisions.size() != 1 && o.fem_divisions.size() != o.materials.size())
          throw InputError(command + ": --fem-divisions gives " +
                           std::to_string(o.fem_divisions.size()) + " values for " +
                           std::to_string(o.materials.size()) +
                           " materials: give one for every material, or one per material");
        for (const unsigned M : o.fem_divisions)
          if (M == 0)
            throw InputError(command + ": --fem-divisions must be at least 1");
        if (o.converged_degree == 1 && o.converged_mesh.empty() && !o.converged_cases.empty())
          throw InputError(command + ": the converged truth with P1 elements on the scene's own mesh "
                           "is the truth itself: give a finer mesh (--converged-mesh), or degree 2");
        // Other meshes of the body: read before any run, so a bad file is refused at once (the
        // scene's own mesh read once for them all).
        decltype(fem::read_gmsh(base.mesh_file).vertices) body;
        const auto same_body = [&](const std::string &other) {
          if (body.empty())
            body = fem::read_gmsh(base.mesh_file).vertices;
          irdm::validation::check_same_body(body, fem::read_gmsh(other).vertices, command + ": '" + other + "'");
        };
        if (!o.converged_mesh.empty())
          same_body(o.converged_mesh);
        if (!o.converged_check_meshes.empty() && (o.converged_mesh.empty() || o.converged_degree == 0))
          throw InputError(command + ": --converged-check-mesh checks the truth on --converged-mesh: "
                           "give that mesh too");
        for (const std::string &mesh : o.converged_check_meshes)
          same_body(mesh);
      }
    } // namespace

    BaseScene
    read_base_scene(const FreeBodyValidationOptions &o, const std::string &command)
    {
      std::ifstream in(o.scene);
      if (!in)
        throw InputError(command + ": cannot read the scene '" + o.scene + "'");
      std::stringstream text;
      text << in.rdbuf();
      BaseScene b{text.str(), fem::parse_scene(text.str(), fs::path(o.scene).parent_path().string(), o.scene)};
      check_options(o, b.scene, command);
      return b;
    }

    void
    run_materials(const FreeBodyValidationOptions &o, const std::string &base_text, FreeStudy &study,
                  std::ostream &log)
    {
      // The reduced models first: a file of no material, of a grounded body, of another time
      // step, or two of one name are refused before the long work.
      const double tau = fem::parse_scene(base_text, fs::path(o.scene).parent_path().string(), o.scene).time_step;
      std::vector<std::string> names;
      for (const std::string &file : o.reduced_models)
        {
          const std::string name = fs::path(file).stem().string();
          if (std::find(names.begin(), names.end(), name) != names.end())
            throw InputError("--reduced-model: two files named '" + name + "' would be one method; rename one");
          names.push_back(name);
          const ReducedNonlinearModel model = load_reduced_nonlinear_model(file, tau);
          if (model.rigid_modes != 6)
            throw InputError("--reduced-model '" + file + "' is a grounded body's model (no rigid "
                             "modes in its basis): a free case needs one made from the free scene");
          const double E = young_modulus(model);
          if (std::none_of(o.materials.begin(), o.materials.end(),
                           [&](const double m) { return std::abs(m - E) <= 1e-6 * m; }))
            throw InputError("--reduced-model '" + file + "': its Young's modulus, " +
                             std::to_string(E) + " Pa, is none of the run's materials");
        }
      for (size_t m = 0; m < o.materials.size(); ++m)
        run_material(o, base_text, o.materials[m],
                     o.fem_divisions.size() == 1 ? o.fem_divisions[0] : o.fem_divisions[m], study, log);
    }
  } // namespace free_body

  void
  run_free_body_validation(const FreeBodyValidationOptions &o, std::ostream &log)
  {
    const free_body::BaseScene base = free_body::read_base_scene(o, "validate-free");
    const std::string dir = (fs::path(o.report_dir) / "free").string();
    fs::create_directories(dir);
    fs::create_directories(o.model_dir);
    // Two runs never write the same report or models at once.
    const OutputLock report_lock((fs::path(dir) / "free.csv").string());
    const OutputLock models_lock((fs::path(o.model_dir) / "free_cat").string());

    free_body::FreeStudy study;
    free_body::run_materials(o, base.text, study, log);
    const free_body::FreeTables tables = free_body::write_free_csvs(dir, o, study, base.scene.density);
    // Charts (matplotlib from Debian); the report stands without them, and shows those this
    // run drew (a chart of a case the run left out is not drawn).
    for (const char *chart : free_body::charts)
      fs::remove(fs::path(dir) / chart);
    if (!o.plot_script.empty())
      {
        const std::string cmd = "/usr/bin/python3 '" + o.plot_script + "' '" + dir + "'";
        if (std::system(cmd.c_str()) != 0)
          log << "validate-free: the charts were not drawn (" << cmd << " failed)" << std::endl;
      }
    free_body::write_free_report(dir, o, study, base.scene, tables);
    log << "validate-free: wrote " << dir << "/free.csv, series.csv, stability.csv, report.md"
        << std::endl;
  }
} // namespace irdm::validation
