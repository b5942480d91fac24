#include <irdm/point_interaction.h>
#include <irdm/representative_interaction.h>
#include <irdm/state_space_interaction.h>
#include <irdm_common/error.h>
#include <irdm_common/files.h>
#include <irdm_common/format.h>
#include <reference_fem/scene.h>
#include <validation/model_sizing.h>

#include <cmath>
#include <filesystem>
#include <memory>

#include "compression_study.h"
#include "scene_runs.h"

namespace irdm::validation
{
  namespace
  {
    /// The scene checked against the model, and the exact model's closed loop on it.
    struct ExactRun
    {
      fem::Scene scene;
      Series     run;
      double     bound = 0; // a run past 10 x the exact peak force is stopped, unstable
    };

    ExactRun
    exact_run(const std::string &scene_file, const ImpulseResponseModel &model, const double tolerance)
    {
      if (!(tolerance > 0 && tolerance < 1))
        throw InputError("--tolerance must be a fraction in (0, 1), for example 0.02");
      ExactRun e;
      e.scene = fem::read_scene(scene_file);
      if (std::abs(e.scene.time_step - model.time_step) > 1e-12 * model.time_step)
        throw InputError("the scene '" + scene_file + "' steps at " + fmt(e.scene.time_step) +
                         " s, the model at " + fmt(model.time_step) + " s");
      if (model.length < e.scene.n_steps())
        throw InputError("the model's responses (T = " + std::to_string(model.length) +
                         ") are shorter than the scene (" + std::to_string(e.scene.n_steps()) +
                         " steps): the direct convolution would not be the exact model there; "
                         "precompute with --length " + std::to_string(e.scene.n_steps()));
      if (e.scene.probes.empty())
        throw InputError("the scene '" + scene_file + "' has no probe: nothing to run in closed loop");
      PointInteraction exact_runtime(model);
      e.run   = run_irdm(e.scene, model, exact_runtime, true);
      e.bound = 10 * peak_force(e.run);
      return e;
    }

    /// One size's closed loop against the exact run, logged; true when within the tolerance.
    template <class Interaction, class Model>
    bool
    try_size(const ExactRun &e, const Model &m, const double setting, const char *name,
             const double tolerance, std::vector<SizeTried> &tried, std::ostream &log)
    {
      Interaction          runtime(m);
      const CompressionRow row = measured_row(run_irdm(e.scene, m, runtime, true, e.bound), e.run);
      const SizeTried      t{setting, row.errors.force_rel_l2, row.errors.disp_rms, row.stable};
      tried.push_back(t);
      log << "  " << name << " " << fmt(setting, "%.6g") << ": force " << fmt(t.force_error)
          << ", displacement " << fmt(t.displacement_error) << (t.stable ? "" : ", unstable") << "\n";
      return t.stable && t.force_error <= tolerance && t.displacement_error <= tolerance;
    }

    template <class Realize>
    SizedModel
    state_space_within(const ExactRun &e, const unsigned largest, const double tolerance,
                       Realize &&realize, std::ostream &log)
    {
      SizedModel out;
      for (const unsigned order : order_grid())
        {
          if (order > largest)
            break;
          StateSpaceModel ss = realize(order);
          if (try_size<StateSpaceInteraction>(e, ss, order, "r", tolerance, out.tried, log))
            {
              out.model = std::move(ss);
              break;
            }
        }
      return out;
    }
  } // namespace

  namespace
  {
    template <class Interaction, class Model>
    ClosedLoopDifference
    closed_loop_of(const std::string &scene_file, const ImpulseResponseModel &reference,
                   const Model &model)
    {
      const ExactRun e = exact_run(scene_file, reference, 0.5); // no tolerance is applied here
      if (std::abs(model.time_step - reference.time_step) > 1e-12 * reference.time_step)
        throw InputError("the model steps at " + fmt(model.time_step) + " s, the scene at " +
                         fmt(e.scene.time_step) + " s");
      Interaction          runtime(model);
      const Series         run = run_irdm(e.scene, model, runtime, true, e.bound);
      const CompressionRow row = measured_row(run, e.run);
      ClosedLoopDifference d{row.errors.force_rel_l2, row.errors.disp_rms, peak_force(e.run), row.stable};
      for (const auto &p : e.scene.probes)
        d.coupled = d.coupled || p.coupling_stiffness > 0 || p.coupling_damping > 0;
      if (d.coupled)
        {
          const CouplingRun mine{0, 0, e.scene.time_step, "model", run};
          const CouplingRun exact{0, 0, e.scene.time_step, "reference", e.run};
          d.passive           = coupling_passive(mine, d.reference_peak_force);
          d.reference_passive = coupling_passive(exact, d.reference_peak_force);
        }
      return d;
    }
  } // namespace

  ClosedLoopDifference
  closed_loop_difference(const std::string &scene_file, const ImpulseResponseModel &reference,
                         const ImpulseResponseModel &model)
  {
    return closed_loop_of<PointInteraction>(scene_file, reference, model);
  }

  ClosedLoopDifference
  closed_loop_difference(const std::string &scene_file, const ImpulseResponseModel &reference,
                         const StateSpaceModel &model)
  {
    return closed_loop_of<StateSpaceInteraction>(scene_file, reference, model);
  }

  const std::vector<unsigned> &
  order_grid()
  {
    static const std::vector<unsigned> grid = {25,  50,  75,  100,  150,  200,  300,  400,  500,
                                               600, 800, 1000, 1200, 1600, 2000, 2500, 3000, 4000};
    return grid;
  }

  SizedModel
  era_within_tolerance(const std::string &scene_file, const ImpulseResponseModel &model,
                       const double tolerance, const EraOptions &options, std::ostream &log)
  {
    const ExactRun e = exact_run(scene_file, model, tolerance);
    log << "sizing: the exact model's closed loop on '" << scene_file << "' (" << e.scene.n_steps()
        << " steps); ERA orders up to " << options.order << ", tolerance " << fmt(tolerance) << "\n";
    const auto hankel = prepare_era(model, options);
    return state_space_within(
      e, options.order, tolerance, [&](const unsigned r) { return realize_era(model, *hankel, r); }, log);
  }

  SizedModel
  balanced_within_tolerance(const std::string &scene_file, const ImpulseResponseModel &model,
                            const double tolerance, const BalancedOptions &options, std::ostream &log)
  {
    const ExactRun e = exact_run(scene_file, model, tolerance);
    log << "sizing: the exact model's closed loop on '" << scene_file << "' (" << e.scene.n_steps()
        << " steps); balanced truncation up to order " << options.order << ", tolerance "
        << fmt(tolerance) << "\n";
    const auto gramians = prepare_balanced(model, options);
    return state_space_within(
      e, options.order, tolerance,
      [&](const unsigned r) { return realize_balanced(model, *gramians, r); }, log);
  }

  SizedRepresentatives
  representatives_within_tolerance(const std::string &scene_file, const ImpulseResponseModel &model,
                                   const double tolerance, const CompressionOptions &options,
                                   std::ostream &log)
  {
    const ExactRun e = exact_run(scene_file, model, tolerance);
    log << "sizing: the exact model's closed loop on '" << scene_file << "' (" << e.scene.n_steps()
        << " steps); representatives (blend " << options.blend << ") from theta 0.5 up, tolerance "
        << fmt(tolerance) << "\n";
    SizedRepresentatives out;
    for (const double theta : {0.5, 0.6, 0.7, 0.8, 0.85, 0.9, 0.95, 0.98, 0.99, 0.995, 0.999, 1.0})
      {
        CompressionOptions o = options;
        o.theta              = theta;
        RepresentativeModel c = compress(model, o);
        if (try_size<RepresentativeInteraction>(e, c, theta, "theta", tolerance, out.tried, log))
          {
            out.model = std::move(c);
            break;
          }
      }
    return out;
  }

  SizedPrecompute
  precompute_within_tolerance(const std::string &scene_file, const PrecomputeSize what,
                              const double tolerance, const fem::PrecomputeOptions &options,
                              std::ostream &log)
  {
    namespace fs = std::filesystem;
    const fem::Scene scene = fem::read_scene(scene_file);
    // Scratch models beside the output, removed whatever happens.
    struct Scratch
    {
      std::string path;
      ~Scratch()
      {
        std::error_code ec;
        fs::remove(path, ec);
        fs::remove(path + ".part", ec); // a precompute that failed keeps its part to resume
      }
    } exact_file{options.output + ".exact.h5"}, try_file{options.output + ".try.h5"};
    // The chosen model takes the output's name (fsync, rename, fsync the folder).
    const auto keep = [&](const std::string &from) { commit_part_file(from, options.output); };
    const auto precompute = [&](fem::PrecomputeOptions o, const std::string &path) {
      o.output  = path;
      o.restart = true;
      o.log     = nullptr;
      return fem::precompute_impulse_responses(scene, o);
    };

    fem::PrecomputeOptions exact_options = options;
    exact_options.modes.reset();
    const auto exact_report = precompute(exact_options, exact_file.path);
    if (exact_report.sparse)
      throw InputError("precompute --tolerance: the scene's " + std::to_string(exact_report.n_free) +
                       " free DoFs are beyond the dense route, so there is no every-mode model "
                       "to size against");
    const ImpulseResponseModel exact_model = load_model(exact_file.path, scene.time_step);
    const ExactRun             e           = exact_run(scene_file, exact_model, tolerance);
    log << "sizing: the exact model (" << exact_report.n_free << " modes, T = " << exact_model.length
        << ") in closed loop on '" << scene_file << "' (" << e.scene.n_steps() << " steps); "
        << (what == PrecomputeSize::modes ? "lowest modes" : "length") << ", tolerance "
        << fmt(tolerance) << "\n";

    SizedPrecompute out;
    const std::vector<unsigned> grid =
      what == PrecomputeSize::modes
        ? std::vector<unsigned>{10, 25, 50, 100, 200, 400, 800, 1600, 3200, 6400}
        : std::vector<unsigned>{50, 100, 150, 200, 300, 400, 500, 750, 1000, 1500, 2000, 3000, 5000};
    const unsigned beyond = what == PrecomputeSize::modes ? exact_report.n_free : exact_model.length;
    for (const unsigned size : grid)
      {
        if (size >= beyond)
          break;
        fem::PrecomputeOptions o = exact_options;
        if (what == PrecomputeSize::modes)
          o.modes = size;
        else
          o.length = size;
        precompute(o, try_file.path);
        const ImpulseResponseModel m = load_model(try_file.path, scene.time_step);
        if (try_size<PointInteraction>(e, m, size, what == PrecomputeSize::modes ? "modes" : "T",
                                       tolerance, out.tried, log))
          {
            keep(try_file.path);
            out.size = size;
            return out;
          }
      }
    // None smaller: the exact model itself.
    out.tried.push_back({double(what == PrecomputeSize::modes ? 0 : exact_model.length), 0, 0, true});
    keep(exact_file.path);
    out.size = what == PrecomputeSize::modes ? 0 : exact_model.length;
    return out;
  }
} // namespace irdm::validation
