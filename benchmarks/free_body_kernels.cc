// Google Benchmark of a free body's step (irdm/free_body.h) with the moving frame's forces on
// the deformation and without: the cat spinning at (3, 8, -5) rad/s in free flight (no plane,
// no gravity), K modes in the force loop, after 200 steps of warm-up. The ratios to the step
// without any spin term are printed at the end: what each term costs, side by side in one run.
//
//   irdm_free_kernels FREE_MODEL.h5 [K] [google-benchmark flags]
// FREE_MODEL.h5: a free body's model, route 2 (irdm precompute of
// validation/scenes/free/free_cat.json; validate-free writes one in its --model-dir). K: the
// force loop's modes (default 300).
#include <irdm/free_body.h>
#include <irdm/modal_model.h>
#include <irdm_common/error.h>

#include <benchmark/benchmark.h>

#include "time_collector.h"

#include <cstdio>
#include <memory>
#include <string>
#include <vector>

namespace
{
  std::unique_ptr<irdm::ModalModel> g_modal;

  struct Variant
  {
    std::string name;
    bool        spin = false, frame = false; // centrifugal + deformed inertia; frame forces
    unsigned    frame_modes = 0;
    bool        momentum    = false; // the deformation's momentum in the rigid body
  };

  void
  run(benchmark::State &state, const Variant &v)
  {
    irdm::FreeBodyOptions o;
    o.gravity     = Eigen::Vector3d::Zero();
    o.centrifugal = o.deformed_inertia = v.spin;
    o.euler = o.spin_softening = o.coriolis = v.frame;
    o.frame_modes                           = v.frame_modes;
    o.deformation_momentum                  = v.momentum;
    irdm::FreeBodyInteraction body(*g_modal, o);
    body.rigid().set_velocity(Eigen::Vector3d::Zero(), Eigen::Vector3d(3, 8, -5));
    for (int n = 0; n < 200; ++n)
      body.step(nullptr, 0);
    for (auto _ : state)
      {
        if (!body.step(nullptr, 0))
          {
            state.SkipWithError("a step was refused");
            return;
          }
        benchmark::ClobberMemory();
      }
  }
} // namespace

int
main(int argc, char **argv)
{
  benchmark::Initialize(&argc, argv);
  if (argc < 2 || std::string(argv[1]) == "--help")
    {
      std::fprintf(stderr, "Usage: irdm_free_kernels FREE_MODEL.h5 [K] [benchmark flags]\n"
                           "FREE_MODEL.h5: a free body's model (route 2)\n");
      return argc < 2 ? 2 : 0;
    }
  unsigned K = 300;
  try
    {
      if (argc > 2)
        K = static_cast<unsigned>(std::stoul(argv[2]));
      const irdm::ImpulseResponseModel model = irdm::load_model(argv[1]);
      irdm::ModalModelOptions          mo;
      mo.force_modes   = std::min(K, model.modes.n_modes);
      mo.surface_modes = std::min(100u, mo.force_modes);
      g_modal = std::make_unique<irdm::ModalModel>(irdm::make_modal_model(model, mo));
      if (g_modal->inertial_coupling.empty())
        throw irdm::InputError(std::string("'") + argv[1] + "' holds no inertial couplings "
                               "(a free body's model of this version)");
    }
  catch (const std::exception &e)
    {
      std::fprintf(stderr, "irdm_free_kernels: error: %s\n", e.what());
      return 2;
    }
  std::vector<Variant> variants = {{"rigid body and modes", false, false, 0},
                                   {"+ centrifugal, deformed inertia", true, false, 0}};
  for (const unsigned r : {0u, 100u, 50u, 25u})
    variants.push_back({"+ frame forces on " + (r ? std::to_string(r) : std::string("every held")) +
                          " modes",
                        true, true, r});
  for (const unsigned r : {50u, 25u})
    variants.push_back({"+ frame forces and momentum on " + std::to_string(r) + " modes", true, true, r, true});
  for (const auto &v : variants)
    benchmark::RegisterBenchmark(v.name.c_str(), [v](benchmark::State &s) { run(s, v); })
      ->Unit(benchmark::kMicrosecond);
  irdm_bench::TimeCollector collector;
  benchmark::RunSpecifiedBenchmarks(&collector);
  std::printf("\nfree-body step, K = %u of %u modes, couplings held for %u: ratio to '%s'\n",
              g_modal->force_modes, g_modal->n_modes, g_modal->inertial_modes,
              variants[0].name.c_str());
  for (const auto &[name, us] : collector.times)
    std::printf("  %-45s %8.2f us  %.3f\n", name.c_str(), us,
                collector.times.empty() ? 0.0 : us / collector.times[0].second);
  return 0;
}
