#pragma once
// Internal to validation/: the point validation's runner. Each scene of validation/scenes/ runs
// through the FEM and through IRDM on its own restricted model (point_runs.cc); the full cat
// model gives the seed's Table 1 (point_full_model.cc); the report writer turns the rows into
// reports/<scene>/ and reports/validation.md (point_report.cc).
#include <reference_fem/impulse_response.h>
#include <reference_fem/scene.h>
#include <validation/point_validation.h>

#include "compression_study.h"
#include "scene_runs.h"

#include <filesystem>
#include <optional>
#include <ostream>
#include <string>
#include <vector>

namespace irdm::validation::points
{
  /// validate writes its working models into --models and removes each after use: a file
  /// already there is someone's, and is never overwritten or removed.
  void
  refuse_existing_model(const std::string &path);

  /// Virtual coupling's stable region on a scene with a coupled probe: every probe coupled at
  /// stiffness x {0.1 .. 100} and damping x {0, 1, 10} of the scene's own, and rigid; IRDM at
  /// tau (exact against the FEM at tau) and the FEM at tau/10; then IRDM from a model
  /// precomputed at tau/10 against the FEM at tau/10, coupled and rigid.
  struct CouplingSweep
  {
    double                   k0 = 0, b0 = 0; // N/m, N s/m: the scene's own
    double                   fem_peak = 0;   // N, the FEM's peak at tau (the bound's scale)
    std::vector<CouplingRun> runs;           // pairs: IRDM at tau, FEM at tau/10
    double                   fine_tau = 0;
    unsigned                 fine_vertices = 0, fine_length = 0; // the tau/10 model
    std::vector<CouplingRun> fine; // pairs (coupled, then rigid): IRDM, FEM, both at tau/10
  };

  /// One scene's validation.
  struct SceneRun
  {
    std::string          file;
    fem::Scene           scene;
    unsigned             N = 0; // steps
    fem::PrecomputeReport pre;
    unsigned             n_inputs = 0, n_outputs = 0, length = 0; // the model's
    // (a) Exactness: the FEM at tau, and the untruncated model in double and in float.
    Series               fem_run, irdm_full, irdm_force; // irdm_force: the force loop alone
    Errors               exact, exact_float;
    bool                 pass = false; // double within 1e-9
    // (b) Truncation: the model cut after each T.
    std::vector<unsigned> taps;
    std::vector<Errors>   truncated;
    // (c) Time step: the contact phase, bilateral, at tau against the FEM at tau/10; and the
    // whole scene at tau/10 with its own (unilateral) contact.
    fem::Scene           phase;
    Series               phase_irdm, phase_fine, fem_fine_unilateral;
    Errors               step_irdm, step_fem;
    double               peak_coarse = 0, peak_fine = 0;
    bool                 fine_finite = true;
    // (e) Compression, and (f) on scenes with a coupled probe.
    std::vector<CompressionRow>  compression;
    std::optional<CouplingSweep> coupling;
  };

  /// Runs one scene (its model precomputed into --models and removed after use).
  SceneRun
  run_scene(const std::string &file, const PointValidationOptions &o, std::ostream &log);

  /// The full cat model (every free surface DoF in and out, or a sample of the inputs):
  /// the seed's Table 1 by representative waveforms, and every compressor in closed loop on the
  /// first scene.
  struct FullModelRun
  {
    std::string                 scene;
    unsigned                    stride = 1;
    fem::PrecomputeReport       pre;
    unsigned                    n_inputs = 0, n_outputs = 0, length = 0;
    double                      waveforms = 0, h_bytes = 0; // H as float
    std::vector<std::vector<std::string>> table1; // Table 1's rows, per theta and original
    std::vector<CompressionRow> rows;
  };

  FullModelRun
  run_full_model(const std::string &first_scene, const PointValidationOptions &o,
                 std::ostream &log);

  /// reports/<scene>/: series.csv, truncation.csv, timestep.csv, compression.csv, coupling.csv
  /// and report.md (validation/templates/scene.md).
  void
  write_scene_report(const std::filesystem::path &dir, const SceneRun &run);

  /// The scene's row of validation.md's table.
  std::string
  summary_row(const SceneRun &run);

  /// reports/validation.md (validation/templates/validation.md) and
  /// full_model_compression.csv when the full model ran.
  void
  write_validation_summary(const PointValidationOptions &o, const std::string &scenes_table,
                           const std::vector<std::pair<std::string, std::vector<CompressionRow>>> &compression,
                           const std::optional<FullModelRun> &full);
} // namespace irdm::validation::points
