#pragma once
// Internal to validation/: the compression study of one scene (issue 4): every compressor and
// setting run in closed loop on the scene, errors against the FEM, time per step measured in
// the same run, memory, stability. Writes compression.csv; returns the report section.
#include <irdm/model.h>
#include <irdm/state_space_model.h>
#include <reference_fem/scene.h>

#include <ostream>
#include <string>
#include <vector>

#include "scene_runs.h"

namespace irdm::validation
{
  struct CompressionRow
  {
    std::string method;    // "FEM", "IRDM direct", "representatives", "interpolated", "modal",
                           // "era", "balanced"
    std::string setting;   // e.g. "theta 0.90", "M 100, L 2"
    double      value = 0; // theta or M (chart label)
    double      bytes = 0, percent = 0; // memory, and % of the same model's H stored as float
    double      rep_percent = -1;       // representatives / waveforms, % (-1: n/a)
    double      build_seconds = 0;
    Errors      errors;
    double      force_loop_us = 0, surface_us = 0;
    bool        stable      = true;
    double      diverged_at = -1;
  };

  /// The measured part of a row: errors of a closed-loop run against the FEM's, its time per
  /// step, and whether it stayed bounded.
  CompressionRow
  measured_row(const Series &run, const Series &fem_run);

  /// Runs the scene through every compressor; `model` is the scene's untruncated model and
  /// fem_run the FEM at the same step (ground truth).
  std::vector<CompressionRow>
  compression_study(const fem::Scene &scene, const ImpulseResponseModel &model,
                    const Series &fem_run, std::ostream &log);

  /// The realization identified from H alone (irdm compress --method era) at each order, in
  /// closed loop on the scene (an order the data cannot support is logged and left out).
  std::vector<CompressionRow>
  era_rows(const fem::Scene &scene, const ImpulseResponseModel &model, const Series &fem_run,
           const std::vector<unsigned> &orders, std::ostream &log, const EraOptions &base = {});

  /// Balanced truncation of the model's modal realization (irdm compress --method balanced)
  /// at each order, in closed loop on the scene.
  std::vector<CompressionRow>
  balanced_rows(const fem::Scene &scene, const ImpulseResponseModel &model, const Series &fem_run,
                const std::vector<unsigned> &orders, std::ostream &log);

  /// compression.csv and the report section (Markdown) for one scene.
  void
  write_compression_csv(const std::string &path, const std::vector<CompressionRow> &rows);
  std::string
  compression_section(const std::vector<CompressionRow> &rows, unsigned n_outputs);
} // namespace irdm::validation
