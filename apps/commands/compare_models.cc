// irdm compare-models: how far a model's H is from a reference model's.
#include "../command.h"

#include <irdm/model.h>
#include <irdm/state_space_model.h>
#include <validation/model_sizing.h>
#include <irdm_common/error.h>
#include <irdm_common/h5.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>
#include <string>

namespace irdm::cli
{
  namespace
  {
    /// compare-models: how far a model's H is from a reference model's (same inputs, outputs,
    /// step and length), e.g. a truncated or coarser-storage model against the exact one.
    void
    print_closed_loop(const std::string &scene, const irdm::validation::ClosedLoopDifference &c)
    {
      std::string coupling;
      if (c.coupled)
        coupling = std::string("; virtual coupling: ") + (c.passive ? "passive" : "NOT passive") +
                   " (the reference: " + (c.reference_passive ? "passive" : "not passive") + ")";
      std::printf("  closed loop on %s (point probes; the reference's H convolved directly, its "
                  "peak force %.6g N): probe force relative L2 %.3e, surface displacement "
                  "relative RMS %.3e%s%s\n",
                  scene.c_str(), c.reference_peak_force, c.force_error, c.displacement_error,
                  c.stable ? "" : ", unstable", coupling.c_str());
    }

    int
    run_compare_models(const std::string &reference_path, const std::string &model_path,
                       const std::string &scene)
    {
      const auto ref = irdm::load_model(reference_path);
      const bool state_space = [&] {
        const irdm::h5::Reader f(model_path);
        return f.has_attribute("/", "format") &&
               f.string_attribute("/", "format") == "irdm-state-space-model";
      }();
      if (state_space)
        {
          // A realization has no H to compare entry by entry: its closed loop is the measure.
          if (scene.empty())
            throw irdm::InputError("compare-models: '" + model_path + "' is a state-space model: "
                                   "give --scene to run both in closed loop");
          const auto ss = irdm::load_state_space_model(model_path, ref.time_step);
          if (ss.input_node_tags != ref.input_node_tags || ss.output_node_tags != ref.output_node_tags)
            throw irdm::InputError("compare-models: '" + model_path + "' and '" + reference_path +
                                   "' differ in their inputs or outputs");
          std::printf("%s (state-space, %u states) against %s:\n", model_path.c_str(), ss.order,
                      reference_path.c_str());
          print_closed_loop(scene, irdm::validation::closed_loop_difference(scene, ref, ss));
          return 0;
        }
      const auto m   = irdm::load_model(model_path, ref.time_step);
      if (m.length != ref.length || m.input_node_tags != ref.input_node_tags ||
          m.output_node_tags != ref.output_node_tags)
        throw irdm::InputError("compare-models: '" + model_path + "' and '" + reference_path +
                               "' differ in their inputs, outputs or length");
      const unsigned nin = ref.n_inputs, nout = ref.n_outputs, T = ref.length;
      double d2 = 0, r2 = 0, worst_input = 0, worst_static = 0, worst_feedthrough = 0;
      for (unsigned k = 0; k < nin; ++k)
        {
          const unsigned kk = 3 * ref.input_output_index[k / 3] + k % 3; // driving point
          double         dk = 0, rk = 0, sum_ref = 0, sum_m = 0;
          for (unsigned s = 0; s < T; ++s)
            {
              for (unsigned j = 0; j < nout; ++j)
                {
                  const double a = ref.h(k, s, j), b = m.h(k, s, j);
                  dk += (a - b) * (a - b);
                  rk += a * a;
                }
              sum_ref += ref.h(k, s, kk);
              sum_m += m.h(k, s, kk);
            }
          d2 += dk;
          r2 += rk;
          worst_input  = std::max(worst_input, std::sqrt(dk / rk));
          worst_static = std::max(worst_static, std::abs(sum_m / sum_ref - 1));
          worst_feedthrough =
            std::max(worst_feedthrough, std::abs(m.h(k, 0, kk) / ref.h(k, 0, kk) - 1));
        }
      std::printf("%s against %s (%u inputs x %u samples x %u outputs):\n"
                  "  H, relative L2 over all entries: %.3e\n"
                  "  H, relative L2 of the worst input: %.3e\n"
                  "  driving-point static compliance sum_s H_kk[s], worst relative: %.3e\n"
                  "  driving-point feed-through H_kk[0], worst relative: %.3e\n",
                  model_path.c_str(), reference_path.c_str(), nin, T, nout, std::sqrt(d2 / r2),
                  worst_input, worst_static, worst_feedthrough);
      if (!scene.empty())
        print_closed_loop(scene, irdm::validation::closed_loop_difference(scene, ref, m));
      return 0;
    }
  } // namespace

  Command
  add_compare_models(CLI::App &app)
  {
    struct Args
    {
      std::string reference, model, scene;
    };
    auto a = std::make_shared<Args>();
    auto *compare = app.add_subcommand("compare-models", "how far a model's H is from a reference model's");
    compare->footer("Relative differences of H between two models of the same inputs, outputs, "
      "time step and length (for example a sparse-route model with --modes against the "
      "all-modes model): over all entries, for the worst input, and of the driving-point "
      "static compliance and feed-through. With --scene, also both models in closed loop on "
      "the scene's probes (and, on a scene with a virtual coupling, whether each stayed "
      "passive); a state-space model (compress --method era or balanced) is compared in closed "
      "loop only.");
    compare->add_option("reference", a->reference, "reference model (from 'irdm precompute')")
      ->required()->check(CLI::ExistingFile);
    compare->add_option("model", a->model, "model to compare")->required()->check(CLI::ExistingFile);
    compare->add_option("--scene", a->scene,
                        "also run both in closed loop on this scene (its step, a probe; the "
                        "models at least as long as it)")
      ->check(CLI::ExistingFile);
    return {compare, [a] { return run_compare_models(a->reference, a->model, a->scene); }};
  }
} // namespace irdm::cli
