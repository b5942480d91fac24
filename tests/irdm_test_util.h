#pragma once
// Shared by the IRDM tests: a small damped cantilever scene (beam_2) with a model region near
// the tip, a scratch folder per test (scratch.h), and a precompute helper.
#include <irdm/model.h>
#include <reference_fem/impulse_response.h>
#include <reference_fem/scene.h>

#include "scratch.h"

#include <cstdlib>
#include <filesystem>
#include <string>

// Heap-allocation counter (test_irdm.cc replaces operator new): armed while true.
extern bool g_count_allocations;
extern long g_allocations;

namespace irdm_test
{
  namespace fs = std::filesystem;
  using namespace irdm;
  // A 0.25 m cantilever (beam_2), soft, damped, generalized-alpha; a probe pushes the top face
  // near the tip down 2 mm and lets go.
  inline std::string
  beam_scene(const std::string &extra)
  {
    return std::string(R"({"format": "irdm-scene/1", "name": "irdm_beam",
      "mesh": {"file": ")") + IRDM_MESH_DIR + R"(/beam_2.msh"}, "fe_degree": 1,
      "material": {"youngs_modulus_Pa": 2e5, "poisson_ratio": 0.4, "density_kg_m3": 1100},
      "damping": {"ratios": [0.05, 0.05], "frequencies_Hz": [0.5, 20]},
      "integrator": {"type": "generalized_alpha", "rho_inf": 0.8},
      "time": {"step_s": 0.002, "duration_s": 0.2}, "fixed_surfaces": ["clamp"],
      "model": {"length": 100, "storage": "double",
                "inputs": {"within": {"center_m": [0.22, 0.0, 0.01], "radius_m": 0.03}}})" +
           extra + "}";
  }

  /// A probe for beam_scene: it presses the top face near the tip 2 mm down along a short
  /// path, holds, eases off and lets go (surface "sides").
  inline constexpr const char *beam_probe = R"(, "probes": [{"name": "finger", "surface": "sides",
      "direction": [0, 0, -1], "unilateral": false, "until_s": 0.15,
      "path": {"times_s": [0, 0.2], "points_m": [[0.21, 0.001, 0.01], [0.235, -0.002, 0.01]]},
      "depth": {"times_s": [0, 0.05, 0.1, 0.12], "values_m": [0, 0.002, 0.002, 0.001]}}])";

  /// "env -i PATH=... HOME=... " for running the CLI without this test process's MPI
  /// variables (a nested mpirun would take them for its own), keeping the sanitizers' options.
  inline std::string
  clean_environment()
  {
    std::string env = "env -i PATH=/usr/bin:/bin HOME=/tmp ";
    for (const char *name : {"ASAN_OPTIONS", "UBSAN_OPTIONS", "LSAN_OPTIONS"})
      if (const char *value = std::getenv(name))
        env += std::string(name) + "='" + value + "' ";
    return env;
  }

  inline ImpulseResponseModel
  make_model(const fem::Scene &s, const std::string &file, fem::PrecomputeOptions o = {})
  {
    o.output  = tmp(file);
    o.restart = true;
    fem::precompute_impulse_responses(s, o);
    return load_model(o.output, s.time_step);
  }
} // namespace irdm_test

