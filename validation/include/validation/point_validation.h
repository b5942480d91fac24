#pragma once
// IRDM point interaction against the reference FEM on the scenes of validation/scenes/:
// exactness (untruncated, double and float), truncation (error against T), time step (both
// against the FEM at tau/10) and cost (time per step, measured in the same run).
#include <optional>
#include <ostream>
#include <string>
#include <vector>

namespace irdm::validation
{
  struct PointValidationOptions
  {
    std::string              scenes_dir = "validation/scenes";
    std::string              report_dir = "reports";
    std::string              model_dir  = "out/models"; // precomputed models (large; not committed)
    std::vector<std::string> only;        // scene names; empty: all
    bool                     full_model = true; // also time the full cat model (T = 500, float)
    // The full model's inputs: every k-th free surface vertex plus the first scene's input
    // region (1: every vertex). Its compression figures are per input, so a sample gives them
    // at a k-th of the memory and time.
    unsigned                 full_model_stride = 1;
    // Samples per response of every scene's model (unset: the scene's model.length); never
    // fewer than the scene's steps, so no scene run truncates.
    std::optional<unsigned>  length;
    std::string              plot_script; // python script for the charts; "" skips charts
  };

  /// Runs every scene, writes reports/<scene>/ and reports/validation.md. Returns true if
  /// every exactness check passed (untruncated double model within 1e-9 of the FEM).
  bool
  run_point_validation(const PointValidationOptions &options, std::ostream &log);
} // namespace irdm::validation
