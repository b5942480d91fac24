// irdm static: static equilibrium under the scene's loads at t = 0.
#include "../command.h"

#include <reference_fem/elastodynamics.h>
#include <reference_fem/scene.h>

#include <cstdio>
#include <memory>
#include <string>

namespace irdm::cli
{
  namespace
  {
    int
    run_static(const std::string &scene_file)
    {
      const auto scene = irdm::fem::read_scene(scene_file);
      check_scene_outputs(scene);
      irdm::fem::ElasticDynamics fem(scene);
      const auto r = fem.solve_static(0.0);
      std::printf("volume %.9g m^3, %u DoFs\n", fem.volume(), fem.n_dofs());
      for (const auto &[name, s] : r.fixed_reaction)
        std::printf("reaction on %s: (%.9g, %.9g, %.9g) N\n", name.c_str(), s[0][0], s[0][1],
                    s[0][2]);
      for (const auto &[name, s] : r.vertex_displacement)
        std::printf("vertex %s (node tag %lld): u = (%.9g, %.9g, %.9g) m\n", name.c_str(),
                    static_cast<long long>(r.vertex_node_tag.at(name)), s[0][0], s[0][1], s[0][2]);
      for (const auto &[name, s] : r.probe_force)
        std::printf("probe %s: F = (%.9g, %.9g, %.9g) N\n", name.c_str(), s[0][0], s[0][1],
                    s[0][2]);
      fem.write_outputs(r);
      return 0;
    }
  } // namespace

  Command
  add_static(CLI::App &app)
  {
    auto static_scene = std::make_shared<std::string>();
    auto *stat = app.add_subcommand("static", "static equilibrium under the scene's loads at t = 0");
    stat->footer("Solves K u = f for the scene's loads (and gravity) at t = 0 with its fixed "
                "surfaces and prescribed displacements, prints the reactions and observed "
                "displacements, and writes the outputs like 'simulate' (one sample).");
    stat->add_option("scene", *static_scene, "scene file (JSON)")->required()->check(CLI::ExistingFile);
    return {stat, [static_scene] { return run_static(*static_scene); }};
  }
} // namespace irdm::cli
