#pragma once
// A model no larger than the scene needs (issue 51): the smallest model of a family (a
// state-space realization identified from H alone, the modal realization's balanced truncation,
// representative waveforms) whose closed loop on the scene stays within a tolerance of the exact
// model's, its size searched upward on a fixed grid.
#include <irdm/model.h>
#include <reference_fem/impulse_response.h>
#include <irdm/representative_model.h>
#include <irdm/state_space_model.h>

#include <ostream>
#include <string>
#include <vector>

namespace irdm::validation
{
  /// One size tried: the order (state-space) or theta (representatives), and its closed loop's
  /// errors relative to the exact model's.
  struct SizeTried
  {
    double setting = 0;
    double force_error = 0, displacement_error = 0; // probe force rel. L2, surface rel. RMS
    bool   stable = true;
  };

  struct SizedModel
  {
    StateSpaceModel        model; // order 0: no order up to the largest met the tolerance
    std::vector<SizeTried> tried; // every size tried, ascending
  };

  struct SizedRepresentatives
  {
    RepresentativeModel    model; // theta 0: no theta of the grid met the tolerance
    std::vector<SizeTried> tried;
  };

  /// Two models of the same body on one scene in closed loop (point probes, a virtual coupling
  /// where the scene's probes have one; the reference's H convolved directly, at least as long
  /// as the scene): the model's probe force (relative L2) and surface displacement (relative
  /// RMS) against the reference's, the reference's peak probe force (N), and, on a coupled
  /// scene, whether the model's run stayed passive (the passivity observer). For a model made
  /// elsewhere (irdm import, irdm calculix) or identified (ERA) against ours.
  struct ClosedLoopDifference
  {
    double force_error = 0, displacement_error = 0, reference_peak_force = 0;
    bool   stable = true, coupled = false, passive = true, reference_passive = true;
  };
  ClosedLoopDifference
  closed_loop_difference(const std::string &scene_file, const ImpulseResponseModel &reference,
                         const ImpulseResponseModel &model);
  ClosedLoopDifference
  closed_loop_difference(const std::string &scene_file, const ImpulseResponseModel &reference,
                         const StateSpaceModel &model);

  /// What `irdm precompute --tolerance` sizes: the lowest modes the sparse route keeps (with
  /// its residual modes), or the responses' length T.
  enum class PrecomputeSize
  {
    modes,
    length
  };

  /// The smallest precomputed model within a tolerance. The exact model is the scene's own
  /// (every mode by the dense route, the given length; at least as long as the scene); the
  /// candidates are the same precompute with fewer lowest modes (10, 25, 50, 100, 200, 400, 800,
  /// 1600, 3200, 6400 below the free DoFs) or a shorter length (50, 100, 150, 200, 300, 400,
  /// 500, 750, 1000, 1500, 2000, 3000, 5000 below the exact one), in closed loop on the scene as
  /// for the other families; the first within the tolerance (the exact model when none is) is
  /// written to options.output, scratch models beside it removed. InputError when the scene is
  /// beyond the dense route (no exact model to size against).
  struct SizedPrecompute
  {
    std::vector<SizeTried> tried;   // ascending; the last is the one written
    unsigned               size = 0; // modes (0: every mode, the exact model) or length
  };
  SizedPrecompute
  precompute_within_tolerance(const std::string &scene_file, PrecomputeSize what, double tolerance,
                              const fem::PrecomputeOptions &options, std::ostream &log);

  /// The state-space orders tried: 25, 50, 75, 100, 150, 200, 300, 400, 500, 600, 800, 1000,
  /// 1200, 1600, 2000, 2500, 3000, 4000, up to the largest allowed.
  const std::vector<unsigned> &
  order_grid();

  /// The scene (a scene file with the model's step and a probe) runs in closed loop with the
  /// exact model (H convolved directly; its responses at least as long as the scene) and with
  /// each realization of ERA (era_within_tolerance: orders up to options.order, one SVD for all,
  /// prepare_era) or of balanced truncation (balanced_within_tolerance, prepare_balanced); the
  /// first whose probe force (relative L2) and surface displacement (relative RMS) both stay
  /// within `tolerance` of the exact run's is taken, so that no smaller order of the grid meets
  /// it.
  SizedModel
  era_within_tolerance(const std::string &scene_file, const ImpulseResponseModel &model,
                       double tolerance, const EraOptions &options, std::ostream &log);
  SizedModel
  balanced_within_tolerance(const std::string &scene_file, const ImpulseResponseModel &model,
                            double tolerance, const BalancedOptions &options, std::ostream &log);

  /// The same for representative waveforms over theta = 0.5, 0.6, 0.7, 0.8, 0.85, 0.9, 0.95,
  /// 0.98, 0.99, 0.995, 0.999, 1 (more representatives as theta grows), options' blend and
  /// delays kept.
  SizedRepresentatives
  representatives_within_tolerance(const std::string &scene_file, const ImpulseResponseModel &model,
                                   double tolerance, const CompressionOptions &options,
                                   std::ostream &log);
} // namespace irdm::validation
