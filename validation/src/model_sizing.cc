#include <irdm/point_interaction.h>
#include <irdm/state_space_interaction.h>
#include <irdm_common/error.h>
#include <irdm_common/format.h>
#include <reference_fem/scene.h>
#include <validation/model_sizing.h>

#include <cmath>

#include "compression_study.h"
#include "scene_runs.h"

namespace irdm::validation
{
  SizedModel
  era_within_tolerance(const std::string &scene_file, const ImpulseResponseModel &model,
                       const double tolerance, const EraOptions &options, std::ostream &log)
  {
    if (!(tolerance > 0 && tolerance < 1))
      throw InputError("--tolerance must be a fraction in (0, 1), for example 0.02");
    const fem::Scene scene = fem::read_scene(scene_file);
    if (std::abs(scene.time_step - model.time_step) > 1e-12 * model.time_step)
      throw InputError("the scene '" + scene_file + "' steps at " + fmt(scene.time_step) +
                       " s, the model at " + fmt(model.time_step) + " s");
    if (model.length < scene.n_steps())
      throw InputError("the model's responses (T = " + std::to_string(model.length) +
                       ") are shorter than the scene (" + std::to_string(scene.n_steps()) +
                       " steps): the direct convolution would not be the exact model there; "
                       "precompute with --length " + std::to_string(scene.n_steps()));
    if (scene.probes.empty())
      throw InputError("the scene '" + scene_file + "' has no probe: nothing to run in closed loop");
    PointInteraction exact_runtime(model);
    const Series     exact = run_irdm(scene, model, exact_runtime, true);
    const double     bound = 10 * peak_force(exact);
    log << "sizing: the exact model's closed loop on '" << scene_file << "' (" << scene.n_steps()
        << " steps); ERA orders up to " << options.order << ", tolerance " << fmt(tolerance) << "\n";
    const auto hankel = prepare_era(model, options);
    SizedModel out;
    for (const unsigned order : {25u, 50u, 75u, 100u, 150u, 200u, 300u, 400u, 500u, 600u, 800u,
                                 1000u, 1200u, 1600u, 2000u, 2500u, 3000u, 4000u})
      {
        if (order > options.order)
          break;
        StateSpaceModel       ss = realize_era(model, *hankel, order);
        StateSpaceInteraction runtime(ss);
        const CompressionRow  row = measured_row(run_irdm(scene, ss, runtime, true, bound), exact);
        const SizedModel::Tried t{order, row.errors.force_rel_l2, row.errors.disp_rms, row.stable};
        out.tried.push_back(t);
        log << "  r " << order << ": force " << fmt(t.force_error) << ", displacement "
            << fmt(t.displacement_error) << (t.stable ? "" : ", unstable") << "\n";
        if (t.stable && t.force_error <= tolerance && t.displacement_error <= tolerance)
          {
            out.model = std::move(ss);
            break;
          }
      }
    return out;
  }
} // namespace irdm::validation
