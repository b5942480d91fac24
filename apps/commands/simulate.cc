// irdm simulate: a scene through the reference FEM, its outputs written as the run makes them.
#include "../command.h"

#include <irdm_common/files.h>
#include <reference_fem/elastodynamics.h>
#include <reference_fem/nonlinear_elasticity.h>
#include <reference_fem/scene.h>

#include <algorithm>
#include <cstdio>
#include <memory>
#include <string>

namespace irdm::cli
{
  namespace
  {
    struct SimulateArgs
    {
      std::string scene;
      bool        quiet = false, allow_large = false;
    };

    /// Results stream to disk in batches of `batch` samples as the run makes them: refuse a run
    /// whose batch would not fit in memory, or whose files would not fit on the disk, before it
    /// starts.
    constexpr unsigned batch = 4096;
    void
    check_simulate_size(const irdm::fem::Scene &scene, const unsigned n_dofs, const bool allow)
    {
      const double samples = irdm::fem::n_samples(scene);
      const double series  = 3.0 * (scene.outputs.vertices.size() + 2 * scene.prescribed.size() +
                                   2 * scene.probes.size() + scene.fixed_surfaces.size() +
                                   scene.planes.size()) +
                            scene.planes.size() + 5;
      const double per_sample = 8 * (series + (scene.outputs.surface ? n_dofs : 0));
      const double memory = 2 * std::min<double>(samples, batch) * per_sample; // batch + copy
      irdm::check_memory_estimate("simulate (a batch of " + std::to_string(batch) + " samples)",
                                  memory, allow);
      if (!scene.outputs.directory.empty())
        irdm::check_disk_estimate("simulate's outputs", scene.outputs.directory,
                                  samples * per_sample * ((scene.outputs.hdf5 ? 1 : 0) +
                                                          (scene.outputs.csv ? 3 : 0)),
                                  allow);
    }

    int
    run_simulate(const SimulateArgs &a)
    {
      const auto scene = irdm::fem::read_scene(a.scene);
      check_scene_outputs(scene);
      const auto progress = a.quiet ? nullptr : print_progress;
      irdm::fem::RunResult result;
      // The outputs are written as the run makes them (batches of `batch` samples), so memory
      // does not grow with the duration; the files get their final names only at the end.
      std::unique_ptr<irdm::fem::ResultWriter> writer;
      const auto open_writer = [&](const unsigned n_dofs) {
        check_simulate_size(scene, n_dofs, a.allow_large);
        if (!scene.outputs.directory.empty())
          writer = std::make_unique<irdm::fem::ResultWriter>(scene, n_dofs, irdm::fem::n_samples(scene));
      };
      const irdm::fem::SampleSink sink = [&](const irdm::fem::RunResult &b) {
        if (writer)
          writer->append(b);
      };
      if (scene.kinematics == irdm::fem::Kinematics::nonlinear)
        {
          irdm::fem::NonlinearElasticity fem(scene);
          open_writer(fem.n_dofs());
          std::fprintf(stderr, "%s: nonlinear (neo-Hookean), %u steps of %g s\n",
                       scene.name.c_str(), scene.n_steps(), scene.time_step);
          result = fem.run(progress, sink, batch);
        }
      else
        {
          irdm::fem::ElasticDynamics fem(scene);
          open_writer(fem.n_dofs());
          std::fprintf(stderr, "%s: %u cells, %u DoFs (P%u), %u steps of %g s\n",
                       scene.name.c_str(), fem.n_cells(), fem.n_dofs(), scene.fe_degree,
                       scene.n_steps(), scene.time_step);
          result = fem.run(progress, sink, batch);
        }
      if (writer)
        writer->finish(result);
      std::printf("setup %.3f s, factorization %.3f s, %u steps in %.3f s (%.3g ms/step)\n",
                  result.setup_seconds, result.factorization_seconds, result.n_steps,
                  result.stepping_seconds, 1e3 * result.stepping_seconds / result.n_steps);
      if (scene.kinematics == irdm::fem::Kinematics::nonlinear)
        {
          std::printf("Newton: %u iterations, %u tangent factorizations\n",
                      result.newton_iterations, result.tangent_factorizations);
          if (result.cut_steps > 0)
            std::printf("cut back: %u of %u steps solved again in parts (Newton failed at the "
                        "full step), the shortest %g s\n",
                        result.cut_steps, result.n_steps, result.smallest_step);
          std::printf("energy: largest rise above the start %.3g J, largest kinetic + strain + "
                      "contact energy %.3g J\n",
                      result.energy_rise, result.energy_scale);
          // With no loads and still planes the energy can only fall: a rise beyond Newton's
          // tolerance and the penalty's kinks (the elastic bouncing ball of the tests: 2.5e-3 of
          // the scale) is the time step's (the 2 kPa cat at 2 ms: 0.34).
          bool still = scene.vertex_forces.empty() && scene.surface_forces.empty();
          for (const auto &p : scene.planes)
            still = still && p.position.times.size() <= 1 && p.normal_path.times.empty();
          if (still && result.energy_rise > 1e-2 * result.energy_scale)
            std::fprintf(stderr,
                         "warning: with no loads and planes that stand still the energy can only "
                         "fall, but it rose by %.3g of its scale: the time step is too coarse "
                         "for these strains (docs/scene-format.md); refine it\n",
                         result.energy_rise / result.energy_scale);
        }
      for (const auto &[name, tag] : result.vertex_node_tag)
        std::printf("vertex %s: node tag %lld\n", name.c_str(), static_cast<long long>(tag));
      for (const auto &[name, f] : result.probe_force)
        std::printf("probe %s: final force (%.6g, %.6g, %.6g) N\n", name.c_str(), f.back()[0],
                    f.back()[1], f.back()[2]);
      for (const auto &[name, f] : result.plane_force)
        {
          double peak = 0, deepest = -1e300;
          for (const auto &F : f)
            peak = std::max(peak, std::sqrt(F[0] * F[0] + F[1] * F[1] + F[2] * F[2]));
          for (const double p : result.plane_penetration.at(name))
            deepest = std::max(deepest, p);
          std::printf("plane %s: peak force %.6g N, deepest penetration %.4g m ", name.c_str(),
                      peak, deepest);
          // Linear kinematics touch by vertex, nonlinear by face penalty.
          const auto k = result.plane_vertex_stiffness.find(name);
          if (k == result.plane_vertex_stiffness.end())
            std::printf("(penalty %.3g Pa/m)\n", result.plane_penalty.at(name));
          else if (k->second > 0)
            std::printf("(vertex contact, %.3g N/m per vertex)\n", k->second);
          else
            std::printf("(vertex contact, rigid)\n");
        }
      if (!scene.outputs.directory.empty())
        std::printf("outputs in %s\n", scene.outputs.directory.c_str());
      return 0;
    }
  } // namespace

  Command
  add_simulate(CLI::App &app)
  {
    auto sim = std::make_shared<SimulateArgs>();
    auto *simulate = app.add_subcommand("simulate", "run a scene with the reference FEM and write its outputs");
    simulate->footer("Runs the scene with the reference FEM (P1/P2 tetrahedra, implicit Newmark or "
      "generalized-alpha) from its initial state to its duration, and writes the outputs the "
      "scene asks for (HDF5, CSV, VTU) into its output directory. \"kinematics\": \"linear\" "
      "(default) is small-strain elasticity; \"nonlinear\" is Total Lagrangian neo-Hookean "
      "elasticity with Newton at each step, rigid planes (penalty contact) and an initial "
      "velocity.");
    simulate->add_option("scene", sim->scene, "scene file (JSON)")->required()->check(CLI::ExistingFile);
    simulate->add_flag("--quiet", sim->quiet, "no progress on stderr");
    simulate->add_flag("--allow-large", sim->allow_large,
                       "run even if the results' memory or disk estimate exceeds what is free");
    return {simulate, [sim] { return run_simulate(*sim); }};
  }
} // namespace irdm::cli
