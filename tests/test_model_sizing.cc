// A model no larger than the scene needs (validation/model_sizing.h): the smallest ERA order
// of the grid whose closed loop on the scene is within the tolerance of the exact model's.
#include <irdm/point_interaction.h>
#include <irdm/representative_interaction.h>
#include <irdm/representative_model.h>
#include <irdm/state_space_interaction.h>
#include <irdm/state_space_model.h>
#include <irdm_common/error.h>
#include <reference_fem/elastodynamics.h>
#include <validation/model_sizing.h>

#include <gtest/gtest.h>

#include <fstream>
#include <sstream>

#include "irdm_test_util.h"
#include "scene_runs.h"

using namespace irdm;
using namespace irdm_test;

namespace
{
  // The closed loop's errors of a realization against the exact model, computed here apart
  // from the sizing's own runner.
  validation::Errors
  errors_of(const fem::Scene &scene, const ImpulseResponseModel &model, const StateSpaceModel &ss)
  {
    PointInteraction      exact(model);
    StateSpaceInteraction era(ss);
    return validation::compare(validation::run_irdm(scene, ss, era, true),
                               validation::run_irdm(scene, model, exact, true));
  }
} // namespace

// The beam under a rigid probe: the order found meets the tolerance when run again apart, the
// grid's order below it (identified afresh, not from the shared SVD) does not, and a model
// shorter than the scene is refused (its direct convolution would not be exact there).
TEST(ModelSizing, TheSmallestOrderWithinTheToleranceAndNoSmaller)
{
  const std::string json  = beam_scene(beam_probe);
  const std::string path  = tmp("sizing_scene.json");
  std::ofstream(path) << json;
  const fem::Scene scene = fem::parse_scene(json, ".");
  const auto       model = make_model(scene, "sizing.h5");
  ASSERT_GE(model.length, scene.n_steps());
  const double     tolerance = 1e-3;
  EraOptions       o;
  o.order = 600;
  std::ostringstream log;
  const auto sized = validation::era_within_tolerance(path, model, tolerance, o, log);
  ASSERT_GT(sized.model.order, 0u) << log.str();
  ASSERT_GE(sized.tried.size(), 2u);
  EXPECT_EQ(sized.tried.back().setting, sized.model.order);
  const auto again = errors_of(scene, model, sized.model);
  EXPECT_LE(again.force_rel_l2, tolerance);
  EXPECT_LE(again.disp_rms, tolerance);
  o.order = static_cast<unsigned>(sized.tried[sized.tried.size() - 2].setting);
  const auto below = errors_of(scene, model, identify_era(model, o));
  EXPECT_GT(std::max(below.force_rel_l2, below.disp_rms), tolerance) << "order " << o.order;

  fem::PrecomputeOptions shorter;
  shorter.length = scene.n_steps() / 2;
  const auto short_model = make_model(scene, "sizing_short.h5", shorter);
  EXPECT_THROW(validation::era_within_tolerance(path, short_model, tolerance, o, log), InputError);
  EXPECT_THROW(validation::era_within_tolerance(path, model, 1.5, o, log), InputError);
}

// The same search for the modal realization's balanced truncation (over the order) and for
// representative waveforms (over theta): the size found meets the tolerance run again apart,
// the grid's size below it does not.
TEST(ModelSizing, BalancedTruncationAndRepresentativesAreSizedTheSameWay)
{
  const std::string json = beam_scene(beam_probe);
  const std::string path = tmp("sizing_bt_scene.json");
  std::ofstream(path) << json;
  const fem::Scene scene     = fem::parse_scene(json, ".");
  const auto       model     = make_model(scene, "sizing_bt.h5");
  // A rigid probe amplifies the history's error by the static over the one-step compliance,
  // so the tolerance is looser than ERA's above.
  const double     tolerance = 1e-2;
  std::ostringstream log;

  BalancedOptions bo;
  bo.order         = 400;
  const auto sized = validation::balanced_within_tolerance(path, model, tolerance, bo, log);
  ASSERT_GT(sized.model.order, 0u) << log.str();
  ASSERT_GE(sized.tried.size(), 2u);
  const auto again = errors_of(scene, model, sized.model);
  EXPECT_LE(again.force_rel_l2, tolerance);
  EXPECT_LE(again.disp_rms, tolerance);
  bo.order         = static_cast<unsigned>(sized.tried[sized.tried.size() - 2].setting);
  const auto below = errors_of(scene, model, balanced_truncation(model, bo));
  EXPECT_GT(std::max(below.force_rel_l2, below.disp_rms), tolerance) << "order " << bo.order;

  CompressionOptions co;
  co.threads    = 1;
  const double loose = 0.05; // representatives under a rigid probe: a looser tolerance still
  const auto reps  = validation::representatives_within_tolerance(path, model, loose, co, log);
  ASSERT_GT(reps.model.theta, 0) << log.str();
  ASSERT_GE(reps.tried.size(), 2u);
  const auto representative_errors = [&](const RepresentativeModel &c) {
    PointInteraction          exact(model);
    RepresentativeInteraction runtime(c);
    return validation::compare(validation::run_irdm(scene, c, runtime, true),
                               validation::run_irdm(scene, model, exact, true));
  };
  const auto found = representative_errors(reps.model);
  EXPECT_LE(std::max(found.force_rel_l2, found.disp_rms), loose);
  co.theta             = reps.tried[reps.tried.size() - 2].setting;
  const auto smaller   = representative_errors(compress(model, co));
  EXPECT_GT(std::max(smaller.force_rel_l2, smaller.disp_rms), loose) << "theta " << co.theta;
}

// Two models in closed loop (validation::closed_loop_difference, `irdm compare-models
// --scene`): a model against itself is exactly 0; a realization against its source is what the
// runner measures apart; on a virtual coupling the passivity of both runs is reported, and the
// exact model on the beam's coupled probe is passive.
TEST(ModelSizing, ClosedLoopDifferenceOfTwoModels)
{
  const std::string coupled = R"("unilateral": false, "coupling": {"stiffness_N_m": 30, "damping_N_s_m": 0.05},)";
  std::string       probe   = beam_probe;
  probe.replace(probe.find(R"("unilateral": false,)"), std::string(R"("unilateral": false,)").size(), coupled);
  for (const std::string &p : {std::string(beam_probe), probe})
    {
      const std::string json = beam_scene(p);
      const std::string path = tmp("closed_loop_scene.json");
      std::ofstream(path) << json;
      const fem::Scene scene = fem::parse_scene(json, ".");
      const auto       model = make_model(scene, "closed_loop.h5");
      const auto       self  = validation::closed_loop_difference(path, model, model);
      EXPECT_EQ(self.force_error, 0);
      EXPECT_EQ(self.displacement_error, 0);
      EXPECT_GT(self.reference_peak_force, 0);
      EXPECT_EQ(self.coupled, p != beam_probe);
      EXPECT_TRUE(self.passive);
      EXPECT_TRUE(self.reference_passive);

      EraOptions o;
      o.order             = 200;
      const auto ss       = identify_era(model, o);
      const auto d        = validation::closed_loop_difference(path, model, ss);
      const auto apart    = errors_of(scene, model, ss);
      EXPECT_EQ(d.force_error, apart.force_rel_l2);
      EXPECT_EQ(d.displacement_error, apart.disp_rms);
      EXPECT_GT(d.force_error, 0);
    }
}

// precompute --tolerance: the lowest modes (sparse route with its residual modes) and the length,
// each the smallest of its grid whose closed loop on the scene is within the tolerance of the
// every-mode model's; the size below it on the grid misses; no scratch model is left behind.
TEST(ModelSizing, PrecomputeSizesTheModesAndTheLength)
{
  namespace fs = std::filesystem;
  std::string json = beam_scene(beam_probe);
  json.replace(json.find(R"("duration_s": 0.2)"), 17, R"("duration_s": 0.4)");
  json.replace(json.find(R"("length": 100)"), 13, R"("length": 200)");
  const std::string path = tmp("precompute_sizing.json");
  std::ofstream(path) << json;
  std::ostringstream log;
  for (const auto what : {validation::PrecomputeSize::modes, validation::PrecomputeSize::length})
    {
      const double tolerance = what == validation::PrecomputeSize::modes ? 1e-3 : 5e-2;
      fem::PrecomputeOptions o;
      o.output          = tmp(what == validation::PrecomputeSize::modes ? "modes.h5" : "length.h5");
      const auto sized  = validation::precompute_within_tolerance(path, what, tolerance, o, log);
      ASSERT_GE(sized.tried.size(), 2u) << log.str();
      ASSERT_GT(sized.size, 0u);
      const auto &found = sized.tried.back(), &below = sized.tried[sized.tried.size() - 2];
      EXPECT_LE(std::max(found.force_error, found.displacement_error), tolerance);
      EXPECT_TRUE(!below.stable || std::max(below.force_error, below.displacement_error) > tolerance);
      const auto model = load_model(o.output);
      if (what == validation::PrecomputeSize::modes)
        {
          EXPECT_GT(model.modes.n_modes, sized.size); // the lowest, plus the residual modes
          EXPECT_LT(model.modes.n_modes, fem::ElasticDynamics(fem::read_scene(path)).n_free_dofs())
            << "the every-mode model was written, not the one chosen";
        }
      else
        EXPECT_EQ(model.length, sized.size);
      for (const char *scratch : {".exact.h5", ".try.h5", ".exact.h5.part", ".try.h5.part"})
        EXPECT_FALSE(fs::exists(o.output + scratch)) << scratch;
    }
}
