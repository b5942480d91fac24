// irdm probe-stiffness: the static driving-point stiffness of the scene's probes (N/m).
#include "../command.h"

#include <reference_fem/elastodynamics.h>
#include <reference_fem/scene.h>

#include <cmath>
#include <cstdio>
#include <memory>
#include <string>

namespace irdm::cli
{
  namespace
  {
    int
    run_probe_stiffness(const std::string &scene_file, const double t)
    {
      const auto scene = irdm::fem::read_scene(scene_file);
      irdm::fem::ElasticDynamics fem(scene);
      const auto c = fem.probe_compliance(t);
      std::printf("scene %s: P%u, %u free DoFs, %u cells, cell size (V/cells)^(1/3) %.6g m\n",
                  scene.name.c_str(), scene.fe_degree, fem.n_free_dofs(), fem.n_cells(),
                  std::cbrt(fem.volume() / fem.n_cells()));
      for (size_t p = 0; p < scene.probes.size(); ++p)
        std::printf("probe %s: radius %.6g m, %u vertices, stiffness %.9g N/m along its direction "
                    "at (%.6g, %.6g, %.6g) m\n",
                    scene.probes[p].name.c_str(), scene.probes[p].radius, c.n_vertices[p],
                    c.stiffness[p], c.point[p][0], c.point[p][1], c.point[p][2]);
      std::printf("time: %.2f s (static factorization and solves)\n", c.seconds);
      return 0;
    }
  } // namespace

  Command
  add_probe_stiffness(CLI::App &app)
  {
    struct Args
    {
      std::string scene;
      double      time = 0;
    };
    auto a = std::make_shared<Args>();
    auto *stiffness = app.add_subcommand(
      "probe-stiffness", "static driving-point stiffness of the scene's probes (N/m)");
    stiffness->footer(
      "For each probe of the scene at time --time: the static compliance S = B K^-1 B^T of its "
      "spread B (the 3 vertices of its contact triangle, or for a probe with radius_m the "
      "vertices within that radius by smooth weights) and the stiffness d^T S^-1 d along its "
      "direction d (N/m). A point probe's stiffness falls without bound as the mesh is refined "
      "(a point load); a radius probe's converges. Used by scripts/convergence.sh.");
    stiffness->add_option("scene", a->scene, "scene file (JSON)")
      ->required()
      ->check(CLI::ExistingFile);
    stiffness->add_option("--time", a->time, "time (s) at which the probes' contact "
                                                    "points are taken")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
    return {stiffness, [a] { return run_probe_stiffness(a->scene, a->time); }};
  }
} // namespace irdm::cli
