// irdm modes: the lowest natural frequencies of the fixed body.
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
    run_modes(const std::string &scene_file, const unsigned count)
    {
      const auto scene = irdm::fem::read_scene(scene_file);
      irdm::fem::ElasticDynamics fem(scene);
      const auto f = fem.natural_frequencies(count);
      for (unsigned i = 0; i < f.size(); ++i)
        std::printf("mode %u: %.9g Hz\n", i + 1, f[i]);
      return 0;
    }
  } // namespace

  Command
  add_modes(CLI::App &app)
  {
    struct Args
    {
      std::string scene;
      unsigned    count = 6;
    };
    auto a = std::make_shared<Args>();
    auto *modes = app.add_subcommand("modes", "lowest natural frequencies of the fixed body");
    modes->footer("Lowest natural frequencies (Hz) of the scene's body with its fixed surfaces, "
               "undamped (subspace iteration).");
    modes->add_option("scene", a->scene, "scene file (JSON)")->required()->check(CLI::ExistingFile);
    modes->add_option("--count", a->count, "number of frequencies (at most the free DoFs)")
      ->capture_default_str()
      ->check(CLI::Range(1u, 100000u));
    return {modes, [a] { return run_modes(a->scene, a->count); }};
  }
} // namespace irdm::cli
