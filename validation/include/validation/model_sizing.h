#pragma once
// A model no larger than the scene needs (issue 51): the smallest realization identified from
// H alone (irdm compress --method era) whose closed loop on the scene stays within a
// tolerance of the exact model's, the order searched upward on a fixed grid.
#include <irdm/model.h>
#include <irdm/state_space_model.h>

#include <ostream>
#include <string>
#include <vector>

namespace irdm::validation
{
  struct SizedModel
  {
    struct Tried
    {
      unsigned order = 0;
      double   force_error = 0, displacement_error = 0; // relative, against the exact model
      bool     stable = true;
    };
    StateSpaceModel    model; // order 0: no order up to the largest met the tolerance
    std::vector<Tried> tried; // every order tried, ascending
  };

  /// The orders tried: 25, 50, 75, 100, 150, 200, 300, 400, 500, 600, 800, 1000, 1200,
  /// 1600, 2000, 2500, 3000, 4000, up to options.order. The scene (a scene file with the
  /// model's step) runs in closed loop with the exact model (H convolved directly) and with
  /// each realization; the first whose probe force (relative L2) and surface displacement
  /// (relative RMS) both stay within `tolerance` of the exact run's is taken, so that no smaller
  /// order of the grid meets it. One SVD serves every order (prepare_era).
  SizedModel
  era_within_tolerance(const std::string &scene_file, const ImpulseResponseModel &model,
                       double tolerance, const EraOptions &options, std::ostream &log);
} // namespace irdm::validation
