#pragma once
// A second source of impulse responses: CalculiX (ccx, Debian `calculix-ccx`), an FEM this
// project did not write. For each input DoF of the scene's model region, a CalculiX deck applies
// one force sample of 1 N (the amplitude 0 at t = 0, 1 at tau, 0 from 2 tau on: held during step
// 0 as the HHT / generalized-alpha force interpolation reads it) to the body at rest and steps
// it with *DYNAMIC, DIRECT (fixed step tau); the displacements of the output vertices at every
// step become one input's responses in the exchange layout (docs/model-format.md), which
// `irdm import` turns into a model. docs/calculix.md.
//
// The deck is the scene's body: its mesh as C3D4 elements (P1), its fixed surfaces clamped,
// its material, its Rayleigh damping (*DAMPING), its step. CalculiX integrates with the HHT
// alpha method, which is the scene's integrator exactly for Newmark average acceleration
// (alpha = 0) and for generalized-alpha at rho_inf = 0.5 (alpha_m = 0, alpha_f = 1/3: HHT at
// alpha = -1/3); other integrators are refused. One difference stays: C3D4 integrates the mass
// at the centroid only (rho V / 16 between every pair of vertices) where our FEM's mass is
// consistent; the scene's "mass_matrix": "one_point" gives our FEM CalculiX's.
#include <reference_fem/scene.h>

#include <functional>
#include <optional>
#include <string>

namespace irdm::fem
{
  struct CalculixOptions
  {
    std::string             responses;    // exchange file to write (HDF5, irdm-responses)
    std::string             work_dir;     // a new folder for the decks and CalculiX's output
    std::string             ccx = "ccx";  // the CalculiX executable
    std::optional<unsigned> length;       // samples per response; default scene.model.length
    unsigned                jobs = 2;     // CalculiX runs at once (one thread each)
    bool                    keep_work = false; // keep the decks and CalculiX's output
  };

  struct CalculixReport
  {
    unsigned    n_inputs = 0, n_outputs = 0, length = 0; // DoFs, DoFs, samples
    std::string ccx_version;
    double      seconds = 0; // wall clock of every CalculiX run
  };

  /// Runs CalculiX once per input DoF and writes the exchange file. InputError for a scene it
  /// cannot reproduce (free body, P2, nonlinear kinematics, an integrator HHT is not), for a
  /// missing ccx, or a CalculiX run that failed (its own message quoted).
  CalculixReport
  calculix_responses(const Scene &scene, const CalculixOptions &options,
                     const std::function<void(const std::string &)> &log);
} // namespace irdm::fem
