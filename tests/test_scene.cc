// Scene files: valid input parses to the right values; every kind of bad input is an
// InputError that names the problem.
#include <irdm_common/error.h>
#include <reference_fem/elastodynamics.h>
#include <reference_fem/scene.h>

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <string>

using irdm::InputError;
using irdm::fem::parse_scene;

namespace
{
  const std::string mesh = IRDM_MESH_DIR "/beam_2.msh";

  std::string
  scene(const std::string &extra, const std::string &material =
                                    R"("youngs_modulus_Pa": 2e5, "poisson_ratio": 0.4, "density_kg_m3": 1100)")
  {
    return R"({"format": "irdm-scene/1", "mesh": {"file": ")" + mesh + R"("}, "material": {)" +
           material + R"(}, "time": {"step_s": 0.01, "duration_s": 1})" + extra + "}";
  }

  // Expects an InputError whose message contains `needle`.
  void
  expect_error(const std::string &json, const std::string &needle)
  {
    try
      {
        parse_scene(json, ".");
        ADD_FAILURE() << "no error for: " << json;
      }
    catch (const InputError &e)
      {
        EXPECT_NE(std::string(e.what()).find(needle), std::string::npos)
          << "message '" << e.what() << "' lacks '" << needle << "'";
      }
  }
} // namespace

TEST(Scene, ParsesValuesAndDefaults)
{
  const auto s = parse_scene(scene(R"(, "name": "b", "fixed_surfaces": ["clamp"],
      "integrator": {"type": "generalized_alpha", "rho_inf": 0.8})"), ".");
  EXPECT_EQ(s.name, "b");
  EXPECT_EQ(s.fe_degree, 2u);
  EXPECT_EQ(s.n_steps(), 100u);
  EXPECT_DOUBLE_EQ(s.youngs_modulus, 2e5);
  EXPECT_EQ(s.integrator, irdm::fem::Integrator::generalized_alpha);
  EXPECT_DOUBLE_EQ(s.rho_inf, 0.8);
  EXPECT_EQ(s.initial, irdm::fem::InitialState::rest);
  EXPECT_FALSE(s.gravity_enabled);
}

TEST(Scene, RayleighFromRatiosHitsBothTargets)
{
  const auto ab = irdm::fem::rayleigh_from_ratios(0.02, 1.5, 0.05, 30);
  for (const auto &[zeta, f] : {std::pair{0.02, 1.5}, std::pair{0.05, 30.0}})
    {
      const double w = 2 * M_PI * f;
      EXPECT_NEAR(ab[0] / (2 * w) + ab[1] * w / 2, zeta, 1e-15);
    }
}

TEST(Scene, HistoryIsPiecewiseLinearAndHeldOutside)
{
  const auto s = parse_scene(scene(R"(, "loads": [{"type": "vertex_force",
      "vertex": {"node_tag": 3}, "force_N": [0, 0, -2],
      "history": {"times_s": [0.1, 0.3], "factors": [1, 3]}}])"), ".");
  const auto &h = s.vertex_forces[0].force;
  EXPECT_DOUBLE_EQ(h.at(0.0)[2], -2);
  EXPECT_DOUBLE_EQ(h.at(0.2)[2], -4);
  EXPECT_DOUBLE_EQ(h.at(0.3)[2], -6);
  EXPECT_DOUBLE_EQ(h.at(5.0)[2], -6);
}

TEST(Scene, BadInputIsAClearError)
{
  expect_error("{not json", "malformed JSON");
  expect_error(scene(R"(, "dampin": {})"), "unknown key 'dampin'");
  expect_error(R"({"format": "irdm-scene/1", "mesh": {"file": ")" + mesh +
                 R"("}, "material": {"youngs_modulus_Pa": 1, "poisson_ratio": 0.3,
                 "density_kg_m3": 1}, "time": {"step_s": 0.01, "duration_s": 0.015}})",
               "whole number");
  EXPECT_NO_THROW(parse_scene(scene(""), "."));
}

TEST(Scene, RejectsNonPhysicalValues)
{
  expect_error(scene("", R"("youngs_modulus_Pa": 0, "poisson_ratio": 0.4, "density_kg_m3": 1)"),
               "youngs_modulus_Pa");
  expect_error(scene("", R"("youngs_modulus_Pa": 1, "poisson_ratio": 0.5, "density_kg_m3": 1)"),
               "poisson_ratio");
  expect_error(scene("", R"("youngs_modulus_Pa": 1, "poisson_ratio": 0.3, "density_kg_m3": -1)"),
               "density_kg_m3");
  expect_error(R"({"format": "irdm-scene/1", "mesh": {"file": ")" + mesh +
                 R"("}, "material": {"youngs_modulus_Pa": 1, "poisson_ratio": 0.3,
                 "density_kg_m3": 1}, "time": {"step_s": -0.01, "duration_s": 1}})",
               "step_s");
  expect_error(R"({"format": "irdm-scene/1", "mesh": {"file": ")" + mesh +
                 R"("}, "material": {"youngs_modulus_Pa": 1, "poisson_ratio": 0.3,
                 "density_kg_m3": 1}, "time": {"step_s": 0.01, "duration_s": 0}})",
               "duration_s");
  expect_error(scene(R"(, "integrator": {"type": "generalized_alpha", "rho_inf": 1.5})"),
               "rho_inf");
  expect_error(scene(R"(, "fe_degree": 3)"), "fe_degree");
}

TEST(Scene, RejectsMissingMeshAndInconsistentKeys)
{
  expect_error(R"({"format": "irdm-scene/1", "mesh": {"file": "/nonexistent.msh"},
                   "material": {"youngs_modulus_Pa": 1, "poisson_ratio": 0.3, "density_kg_m3": 1},
                   "time": {"step_s": 0.01, "duration_s": 1}})",
               "does not exist");
  expect_error(scene(R"(, "loads": [{"type": "vertex_force", "vertex": {"node_tag": 3,
      "nearest_to_m": [0, 0, 0]}, "force_N": [0, 0, 1]}])"), "exactly one");
  expect_error(scene(R"(, "loads": [{"type": "vertex_force", "vertex": {"node_tag": 3},
      "force_N": [0, 0, 1], "history": {"times_s": [0, 0], "factors": [1, 2]}}])"),
               "strictly increasing");
  expect_error(scene(R"(, "prescribed_displacements": [{"vertex": {"node_tag": 3},
      "displacement_m": [0, 0, 0.01]}])"), "not zero at t = 0");
  std::string v2 = scene("");
  v2.replace(v2.find("irdm-scene/1"), 12, "irdm-scene/2");
  expect_error(v2, "unknown format");
}

// Virtual coupling and the small-strain law: bad values and misplaced keys are named.
TEST(Scene, CouplingAndMaterialLawAreChecked)
{
  const std::string probe = R"(, "probes": [{"name": "f", "surface": "tip", "direction": [0, 0, -1],
      "path": {"times_s": [0], "points_m": [[0.25, 0.005, 0.01]]},
      "depth": {"times_s": [0, 1], "values_m": [0, 0.001]}, "coupling": )";
  const auto parsed = parse_scene(scene(probe + R"({"stiffness_N_m": 300, "damping_N_s_m": 0.5}}])"), ".");
  EXPECT_EQ(parsed.probes[0].coupling_stiffness, 300);
  EXPECT_EQ(parsed.probes[0].coupling_damping, 0.5);
  expect_error(scene(probe + R"({"stiffness_N_m": 0}}])"), "not both zero");
  expect_error(scene(probe + R"({"stiffness_N_m": -1, "damping_N_s_m": 1}}])"), "stiffness_N_m >= 0");
  expect_error(scene(probe + R"({"spring": 1}}])"), "spring");
  const std::string plate = R"(, "planes": [{"name": "p", "normal": [0, 0, 1],
      "position": {"times_s": [0], "points_m": [[0, 0, -0.01]]}, "coupling": {"stiffness_N_m": 10}}])";
  EXPECT_EQ(parse_scene(scene(plate), ".").planes[0].coupling_stiffness, 10);
  expect_error(scene(R"(, "kinematics": "nonlinear")" + plate), "linear kinematics");
  const std::string m = R"("youngs_modulus_Pa": 2e5, "poisson_ratio": 0.4, "density_kg_m3": 1100, "law": )";
  EXPECT_TRUE(parse_scene(scene(R"(, "kinematics": "nonlinear")", m + R"("linear")"), ".").small_strain_law);
  EXPECT_FALSE(parse_scene(scene(R"(, "kinematics": "nonlinear")", m + R"("linear")"), ".").body_frame_law);
  const irdm::fem::Scene body = parse_scene(scene(R"(, "kinematics": "nonlinear")", m + R"("linear_body_frame")"), ".");
  EXPECT_TRUE(body.small_strain_law && body.body_frame_law);
  expect_error(scene("", m + R"("linear_body_frame")"), "material.law");
  expect_error(scene("", m + R"("linear")"), "material.law");
  expect_error(scene(R"(, "kinematics": "nonlinear")", m + R"("hookean")"), "neo_hookean");
  const irdm::fem::Scene corotational = parse_scene(scene(R"(, "kinematics": "nonlinear")", m + R"("corotational")"), ".");
  EXPECT_TRUE(corotational.corotational_law && !corotational.small_strain_law && !corotational.body_frame_law);
  expect_error(scene("", m + R"("corotational")"), "material.law");
}

TEST(Scene, NothingIsSilentlyTruncated)
{
  // A number too large for a double names its line and key (it was "number overflow").
  expect_error(scene("", R"("youngs_modulus_Pa": 1e400, "poisson_ratio": 0.4, "density_kg_m3": 1)"),
               "key 'youngs_modulus_Pa': the number 1e400");
  // Counts that would wrap at 2^32.
  expect_error(scene(R"(, "outputs": {"every": 4294967297})"), "outputs.every");
  expect_error(scene(R"(, "outputs": {"vtu_every": 4294967296})"), "vtu_every");
  // Names become file names: at most 64 plain characters (57 used to collide VTU frames).
  expect_error(scene(R"(, "name": ")" + std::string(65, 'a') + R"(")"), "at most 64");
  expect_error(scene(R"(, "name": "a*b")"), "letters, digits");
  EXPECT_EQ(parse_scene(scene(R"(, "name": ")" + std::string(64, 'a') + R"(")"), ".").name.size(),
            64u);
}

TEST(Scene, PointsFarFromTheBodyAndLoadsOnFixedVerticesAreRefused)
{
  const auto fem_error = [](const std::string &json, const std::string &needle) {
    try
      {
        irdm::fem::ElasticDynamics fem(parse_scene(json, "."));
        ADD_FAILURE() << "no error for: " << json;
      }
    catch (const InputError &e)
      {
        EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
      }
  };
  // The beam is 0.25 m long: a point 1.7 m away is a mistake, not "the nearest vertex".
  fem_error(scene(R"(, "fixed_surfaces": ["clamp"], "loads": [{"type": "vertex_force",
      "name": "far", "vertex": {"nearest_to_m": [1.7, 0, 0]}, "force_N": [0, 0, -1]}])"),
            "more than a tenth of the body's size");
  // The clamped end (x = 0) is fixed: a load there would act on nothing.
  fem_error(scene(R"(, "fixed_surfaces": ["clamp"], "loads": [{"type": "vertex_force",
      "name": "on_clamp", "vertex": {"nearest_to_m": [0, 0, 0]}, "force_N": [0, 0, -1]}])"),
            "lies on a fixed surface");
}

// The shipped scenes all read, and `irdm validate`'s default folder (validation/scenes, run by
// scripts/main.sh) holds only scenes with probes: a free-body scene put there once stopped the
// main job at its first step ("has no probes"). Free-body scenes live in validation/scenes/free.
TEST(Scene, ShippedScenesReadAndTheValidateFolderHoldsOnlyProbeScenes)
{
  namespace fs = std::filesystem;
  const fs::path source = fs::path(IRDM_MESH_DIR).parent_path();
  int            top = 0, all = 0;
  for (const auto &e : fs::recursive_directory_iterator(source / "validation" / "scenes"))
    {
      if (e.path().extension() != ".json")
        continue;
      SCOPED_TRACE(e.path().string());
      const auto scene = irdm::fem::read_scene(e.path().string());
      ++all;
      if (e.path().parent_path() == source / "validation" / "scenes")
        {
          ++top;
          EXPECT_FALSE(scene.probes.empty()) << "irdm validate would refuse it";
        }
    }
  for (const auto &e : fs::directory_iterator(source / "examples"))
    if (e.path().extension() == ".json")
      {
        SCOPED_TRACE(e.path().string());
        EXPECT_NO_THROW(irdm::fem::read_scene(e.path().string()));
      }
  EXPECT_GE(top, 5); // press, tap, tap_coupled, trace, squeeze
  EXPECT_GT(all, top); // and the free-body scenes below
}
