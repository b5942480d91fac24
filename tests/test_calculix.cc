// CalculiX as a second source of impulse responses (reference_fem/calculix.h): its model is ours
// to the digits its output prints once our FEM assembles CalculiX's C3D4 mass (at the
// centroid), and differs from ours with the consistent mass by the mass rule alone.
#include <irdm/model.h>
#include <irdm/response_exchange.h>
#include <irdm_common/error.h>
#include <reference_fem/calculix.h>
#include <reference_fem/scene.h>

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>

#include "irdm_test_util.h"

using namespace irdm;
using namespace irdm_test;

namespace
{
  std::string
  replaced(std::string json, const std::string &from, const std::string &to)
  {
    const auto at = json.find(from);
    EXPECT_NE(at, std::string::npos) << from;
    return at == std::string::npos ? json : json.replace(at, from.size(), to);
  }

  // The test beam with few inputs (the tip's top corner region) and the given integrator.
  std::string
  calculix_beam(const std::string &integrator, const std::string &extra = "")
  {
    return replaced(replaced(beam_scene(extra),
                             R"("integrator": {"type": "generalized_alpha", "rho_inf": 0.8})",
                             integrator),
                    R"("center_m": [0.22, 0.0, 0.01], "radius_m": 0.03)",
                    R"("center_m": [0.25, 0.0, 0.01], "radius_m": 0.011)");
  }

  double
  relative_l2(const ImpulseResponseModel &a, const ImpulseResponseModel &b)
  {
    double d2 = 0, r2 = 0;
    for (unsigned k = 0; k < a.n_inputs; ++k)
      for (unsigned s = 0; s < a.length; ++s)
        for (unsigned j = 0; j < a.n_outputs; ++j)
          {
            d2 += std::pow(a.h(k, s, j) - b.h(k, s, j), 2);
            r2 += std::pow(b.h(k, s, j), 2);
          }
    return std::sqrt(d2 / r2);
  }

  ImpulseResponseModel
  calculix_model(const fem::Scene &scene, const unsigned length, const std::string &name)
  {
    fem::CalculixOptions o;
    o.responses = tmp(name + "_responses.h5");
    o.work_dir  = tmp(name + "_work");
    o.length    = length;
    fem::calculix_responses(scene, o, {});
    EXPECT_FALSE(std::filesystem::exists(o.work_dir)); // removed unless kept
    import_responses(o.responses, tmp(name + ".h5"));
    return load_model(tmp(name + ".h5"), scene.time_step);
  }
} // namespace

// Generalized-alpha at rho_inf 0.5 (HHT at alpha = -1/3) and Newmark (alpha = 0): CalculiX's
// H equals ours with the one-point mass to its printed 7 digits, on the same node tags and
// named surfaces; against ours with the consistent mass it differs by far more (the mass rule).
TEST(Calculix, ItsModelIsOursWithItsMassRuleToThePrintedDigits)
{
  const std::string one_point = R"(, "mass_matrix": "one_point")";
  for (const auto &[integrator, length] :
       {std::pair<std::string, unsigned>{R"("integrator": {"type": "generalized_alpha", "rho_inf": 0.5})", 60},
        {R"("integrator": {"type": "newmark"})", 20}})
    {
      SCOPED_TRACE(integrator);
      const std::string tag   = std::to_string(length);
      const auto        scene = fem::parse_scene(calculix_beam(integrator), ".");
      fem::PrecomputeOptions o;
      o.length               = length;
      const auto consistent  = make_model(scene, "consistent_" + tag + ".h5", o);
      const auto centroid    =
        make_model(fem::parse_scene(calculix_beam(integrator, one_point), "."), "one_point_" + tag + ".h5", o);
      const auto ccx = calculix_model(scene, length, "ccx_" + tag);
      ASSERT_GE(ccx.n_inputs, 6u);
      ASSERT_LE(ccx.n_inputs, 30u);
      ASSERT_EQ(ccx.input_node_tags, centroid.input_node_tags);
      ASSERT_EQ(ccx.output_node_tags, centroid.output_node_tags);
      ASSERT_EQ(ccx.length, length);
      EXPECT_EQ(ccx.triangles.size(), centroid.triangles.size());
      EXPECT_EQ(ccx.surface_names, centroid.surface_names);
      EXPECT_LT(relative_l2(ccx, centroid), 1e-6);
      EXPECT_GT(relative_l2(ccx, consistent), 1e-3);
      EXPECT_GT(relative_l2(centroid, consistent), 1e-3);
    }
}

// What CalculiX cannot reproduce, or cannot run, is refused before anything is written.
TEST(Calculix, RefusesWhatItCannotReproduce)
{
  fem::CalculixOptions o;
  o.responses = tmp("r.h5");
  o.work_dir  = tmp("work");
  o.length    = 5;
  // Refused with a message naming `about`, nothing written, the work folder gone (or kept, with
  // CalculiX's own output, when CalculiX itself failed).
  const auto refuse = [&](const std::string &json, const std::string &about,
                          const std::string &ccx = "ccx", const bool kept = false) {
    o.ccx = ccx;
    try
      {
        fem::calculix_responses(fem::parse_scene(json, "."), o, {});
        ADD_FAILURE() << "not refused: " << about;
      }
    catch (const InputError &e)
      {
        EXPECT_NE(std::string(e.what()).find(about), std::string::npos) << e.what();
      }
    EXPECT_FALSE(std::filesystem::exists(o.responses));
    EXPECT_EQ(std::filesystem::exists(o.work_dir), kept) << about;
    std::filesystem::remove_all(o.work_dir);
  };
  const std::string hht   = R"("integrator": {"type": "generalized_alpha", "rho_inf": 0.5})";
  const std::string ready = calculix_beam(hht);
  refuse(beam_scene(""), "rho_inf");
  refuse(replaced(ready, R"("fe_degree": 1)", R"("fe_degree": 2)"), "C3D4");
  refuse(replaced(ready, R"("fixed_surfaces": ["clamp"])", R"("fixed_surfaces": [])"), "free body");
  refuse(ready, "cannot run '/nonexistent/ccx'", "/nonexistent/ccx");
  refuse(ready, "CalculiX failed", "/bin/false", true); // a program that fails: its output kept
  std::filesystem::create_directories(o.work_dir); // a work folder that exists
  o.ccx = "ccx";
  EXPECT_THROW(fem::calculix_responses(fem::parse_scene(ready, "."), o, {}), InputError);
  EXPECT_FALSE(std::filesystem::exists(o.responses));
  // The one-point mass is for P1 under linear kinematics only, and no other rule is known.
  EXPECT_THROW(fem::parse_scene(beam_scene(R"(, "mass_matrix": "lumped")"), "."), InputError);
  EXPECT_THROW(fem::parse_scene(replaced(beam_scene(R"(, "mass_matrix": "one_point")"),
                                         R"("fe_degree": 1)", R"("fe_degree": 2)"), "."),
               InputError);
}
