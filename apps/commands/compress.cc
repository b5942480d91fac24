// irdm compress: a model compressed by representative waveforms (seed 000, section 3), or a
// state-space model (ERA from H alone; balanced truncation of the modal realization).
#include "../command.h"

#include <irdm/model.h>
#include <irdm/representative_model.h>
#include <irdm/state_space_model.h>
#include <irdm_common/error.h>
#include <irdm_common/files.h>
#include <irdm_common/format.h>
#include <validation/model_sizing.h>

#include <iostream>
#include <random>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>
#include <string>

namespace irdm::cli
{
  namespace
  {
    struct CompressArgs
    {
      std::string               in, out;
      std::string               method = "representatives";
      irdm::CompressionOptions  o;
      irdm::EraOptions          era;
      double                    tolerance = 0; // > 0: the smallest model within it on scene
      double                    contact_weight = 100; // balanced: the contact rows' weight
      std::string               scene;
      bool                      quiet = false;
      double                    noise = 0;    // > 0: H with Gaussian noise of this std / peak
      unsigned                  noise_seed = 1;
      std::string               noisy_h;      // what add_noise did, in words
    };

    /// A measured-response stand-in: every entry of H (H[0] included) plus Gaussian noise of
    /// standard deviation `fraction` of H's largest entry, from a seeded generator so that a
    /// figure can be drawn again and its spread over seeds reported.
    std::string
    add_noise(irdm::ImpulseResponseModel &m, const double fraction, const unsigned seed)
    {
      if (m.h_double.empty() && m.h_float.empty())
        throw irdm::InputError("compress: --noise needs a model with H (not --modal-only)");
      double peak = 0;
      for (const double x : m.h_double)
        peak = std::max(peak, std::abs(x));
      for (const float x : m.h_float)
        peak = std::max(peak, static_cast<double>(std::abs(x)));
      std::mt19937_64                  rng(seed);
      std::normal_distribution<double> gauss(0.0, fraction * peak);
      for (double &x : m.h_double)
        x += gauss(rng);
      for (float &x : m.h_float)
        x = static_cast<float>(x + gauss(rng));
      return "H with Gaussian noise of standard deviation " + irdm::fmt(fraction) +
             " of its largest entry (" + irdm::fmt(fraction * peak) + " m/N), seed " +
             std::to_string(seed) + " (std::mt19937_64, libstdc++'s normal distribution)";
    }

    /// The sizes a --tolerance search tried, and the one it took (InputError when none).
    void
    print_sized(const CompressArgs &a, const std::vector<irdm::validation::SizeTried> &tried,
                const bool found, const char *size, const std::string &largest)
    {
      for (const auto &t : tried)
        std::printf("%s %.6g: force %.4g, displacement %.4g against the exact model%s\n", size,
                    t.setting, t.force_error, t.displacement_error, t.stable ? "" : " (unstable)");
      if (!found)
        throw irdm::InputError("compress: no " + std::string(size) + " up to " + largest +
                               " keeps the closed loop on '" + a.scene + "' within " +
                               irdm::fmt(a.tolerance) + " of the exact model");
      std::printf("smallest %s within %.4g: %.6g\n", size, a.tolerance, tried.back().setting);
    }

    std::ostream &
    sizing_log(const CompressArgs &a)
    {
      static std::ostream silent(nullptr); // no buffer: writes are dropped
      return a.quiet ? silent : std::cerr;
    }

    int
    run_era(const CompressArgs &a, const irdm::ImpulseResponseModel &model, irdm::OutputLock lock)
    {
      irdm::StateSpaceModel ss;
      if (a.tolerance > 0)
        {
          auto sized = irdm::validation::era_within_tolerance(a.scene, model, a.tolerance, a.era, sizing_log(a));
          print_sized(a, sized.tried, sized.model.order > 0, "order", std::to_string(a.era.order) + " (--order)");
          ss = std::move(sized.model);
        }
      else
        ss = irdm::identify_era(model, a.era);
      if (!a.noisy_h.empty())
        ss.identified_from = a.noisy_h;
      irdm::save_state_space_model(ss, a.in, a.out, std::move(lock));
      const double h_float = 4.0 * model.n_inputs * model.n_outputs * model.length;
      const auto  &hsv     = ss.hankel_singular_values;
      std::printf("identified %s -> %s: order %u (%u real poles, %u pairs; %u pulled onto radius "
                  "%.6g), directions %u in, contact rows + %u out, Hankel %u x %u blocks\n"
                  "Hankel singular values: first %.4g, at the order %.4g (%.3g of the first), "
                  "after it %.4g\n"
                  "size: %.2f MB, %.3g %% of %.1f MB (float H); time %.2f s\n",
                  a.in.c_str(), a.out.c_str(), ss.order, ss.n_real, ss.n_pairs(),
                  ss.poles_pulled_in, ss.stability_radius, ss.input_directions, ss.output_directions, ss.hankel_rows,
                  ss.hankel_columns, hsv[0], hsv[ss.order - 1], hsv[ss.order - 1] / hsv[0],
                  hsv.size() > ss.order ? hsv[ss.order] : 0.0, ss.bytes() / 1e6,
                  100 * ss.bytes() / h_float, h_float / 1e6, ss.identification_seconds);
      return 0;
    }

    int
    run_balanced(const CompressArgs &a, const irdm::ImpulseResponseModel &model, irdm::OutputLock lock)
    {
      irdm::BalancedOptions o;
      o.order            = a.era.order;
      o.stability_radius = a.era.stability_radius;
      o.contact_weight   = a.contact_weight;
      o.log              = a.era.log;
      irdm::StateSpaceModel ss;
      if (a.tolerance > 0)
        {
          auto sized = irdm::validation::balanced_within_tolerance(a.scene, model, a.tolerance, o, sizing_log(a));
          print_sized(a, sized.tried, sized.model.order > 0, "order", std::to_string(o.order) + " (--order)");
          ss = std::move(sized.model);
        }
      else
        ss = irdm::balanced_truncation(model, o);
      irdm::save_state_space_model(ss, a.in, a.out, std::move(lock));
      const double h_float = 4.0 * model.n_inputs * model.n_outputs * model.length;
      const auto  &hsv     = ss.hankel_singular_values;
      double       dropped = 0;
      for (size_t i = ss.order; i < hsv.size(); ++i)
        dropped += hsv[i];
      std::printf("balanced truncation of %s -> %s: order %u of %u states (%u real poles, %u "
                  "pairs; %u pulled onto radius %.6g)\n"
                  "Hankel singular values: first %.4g, at the order %.4g (%.3g of the first); "
                  "twice the %zu computed beyond it: %s%.4g m/N (the bound on H's miss)\n"
                  "size: %.2f MB, %.3g %% of %.1f MB (float H); time %.2f s\n",
                  a.in.c_str(), a.out.c_str(), ss.order, 3 * model.modes.n_modes, ss.n_real,
                  ss.n_pairs(), ss.poles_pulled_in, ss.stability_radius, hsv[0], hsv[ss.order - 1],
                  hsv[ss.order - 1] / hsv[0], hsv.size() - ss.order,
                  ss.singular_values_complete ? "" : "at least ", 2 * dropped, ss.bytes() / 1e6,
                  100 * ss.bytes() / h_float, h_float / 1e6, ss.identification_seconds);
      return 0;
    }

    int
    run_compress(CompressArgs a)
    {
      irdm::check_output_file("--out", a.out, {a.in});
      if (a.tolerance > 0 && a.scene.empty())
        throw irdm::InputError("compress: --tolerance sizes the model on a --scene; give one");
      irdm::OutputLock lock(a.out); // before the work: a second run to --out is refused now
      a.o.log = a.era.log = stderr_log(a.quiet);
      auto model = irdm::load_model(a.in);
      if (a.noise > 0)
        {
          if (a.method != "era")
            throw irdm::InputError("compress: --noise is for --method era (identification from "
                                   "measured responses)");
          if (a.tolerance > 0)
            throw irdm::InputError("compress: --noise with --tolerance would size against the "
                                   "noisy H; size without noise, then identify with it");
          a.noisy_h = add_noise(model, a.noise, a.noise_seed);
        }
      if (a.method == "era")
        return run_era(a, model, std::move(lock));
      if (a.method == "balanced")
        return run_balanced(a, model, std::move(lock));
      irdm::RepresentativeModel c;
      if (a.tolerance > 0)
        {
          auto sized = irdm::validation::representatives_within_tolerance(a.scene, model, a.tolerance, a.o, sizing_log(a));
          print_sized(a, sized.tried, sized.model.theta > 0, "theta", "1");
          c = std::move(sized.model);
        }
      else
        c = irdm::compress(model, a.o);
      irdm::save_representative_model(c, a.in, a.out, std::move(lock));
      const double waveforms = static_cast<double>(model.n_inputs) * model.n_outputs;
      std::printf("compressed %s -> %s: theta %.3g, blend %u\n"
                  "waveforms %.0f: %llu representative (%.3g %%), %llu substituted; mean fit %.4f, "
                  "min fit %.4f, mean delay %.2f steps, largest delay %u\n"
                  "size: representatives %.2f MB + blend tables %.2f MB = %.2f MB, %.3g %% of %.1f MB "
                  "(float H); time %.2f s\n",
                  a.in.c_str(), a.out.c_str(), c.theta, c.blend, waveforms,
                  static_cast<unsigned long long>(c.n_representative()),
                  100 * c.n_representative() / waveforms,
                  static_cast<unsigned long long>(c.n_substituted), c.mean_fit, c.min_fit,
                  c.mean_delay, c.delay_span, c.representative_bytes() / 1e6,
                  (c.bytes() - c.representative_bytes()) / 1e6, c.bytes() / 1e6,
                  100 * c.bytes() / (4 * waveforms * model.length),
                  4 * waveforms * model.length / 1e6, c.compression_seconds);
      return 0;
    }
  } // namespace

  Command
  add_compress(CLI::App &app)
  {
    auto ca = std::make_shared<CompressArgs>();
    auto *compress = app.add_subcommand("compress", "compress a model: representative waveforms (seed 000 sec. 3) or a state-space realization from H alone (ERA)");
    compress->footer("Compresses an impulse-response model (from 'irdm precompute') by representative "
      "waveforms (seed 000, section 3; docs/compression.md): every waveform H_kj is kept as a "
      "representative or replaced by representatives of the same input, delayed (d >= 0 "
      "steps) and scaled, when their correlation reaches theta. The output is a model the "
      "runtime runs directly, with the source's metadata plus theta and the statistics. "
      "With --method era: a discrete state-space model of --order states identified from H "
      "alone by the eigensystem realization algorithm (H[0] kept exactly as the feed-through; "
      "every pole inside the unit circle), a model of kind 'state_space'. With --method "
      "balanced: the same kind of model by balanced truncation of the file's own modal "
      "realization to --order states (needs its /modes; the bound 2 x the dropped Hankel "
      "singular values printed).");
    compress->add_option("model", ca->in, "model file from 'irdm precompute'")->required()->check(CLI::ExistingFile);
    compress->add_option("--out", ca->out, "compressed model to write")->required();
    compress->add_option("--method", ca->method,
                         "representatives (seed 000), era (a state-space realization from H "
                         "alone) or balanced (balanced truncation of the modal realization)")
      ->capture_default_str()
      ->check(CLI::IsMember({"representatives", "era", "balanced"}));
    compress->add_option("--order", ca->era.order, "era, balanced: states kept (the largest Hankel singular values)")
      ->capture_default_str()
      ->check(CLI::Range(1u, 100000u));
    compress->add_option("--input-directions", ca->era.input_directions,
                         "era: the responses are first projected onto this many dominant input "
                         "directions (0: every input, up to 1000; fewer costs a probe's force "
                         "accuracy)")
      ->capture_default_str()
      ->check(CLI::Range(0u, 1000000u));
    compress->add_option("--output-directions", ca->era.output_directions,
                         "era: and onto the input vertices' own output DoFs (exactly) and this "
                         "many dominant directions of the other outputs")
      ->capture_default_str()
      ->check(CLI::Range(0u, 1000000u));
    compress->add_option("--hankel-rows", ca->era.hankel_rows,
                         "era: block rows of the Hankel matrix (0: about 4000 scalar rows)")
      ->capture_default_str()
      ->check(CLI::Range(0u, 1000000u));
    compress->add_option("--hankel-columns", ca->era.hankel_columns,
                         "era: block columns (0: about 4000 scalar columns); rows plus columns "
                         "samples of H are used, at most T - 1")
      ->capture_default_str()
      ->check(CLI::Range(0u, 1000000u));
    compress->add_option("--stability-radius", ca->era.stability_radius,
                         "era, balanced: poles beyond this radius are pulled onto it")
      ->capture_default_str()
      ->check(CLI::Range(1e-6, 1 - 1e-9));
    compress->add_option("--contact-weight", ca->contact_weight,
                         "balanced: the input vertices' own output DoFs weigh this much more "
                         "than the other outputs in the observability Gramian")
      ->capture_default_str()
      ->check(CLI::Range(1.0, 1e12));
    compress->add_option("--tolerance", ca->tolerance,
                         "take the smallest model whose closed loop on --scene keeps the probe "
                         "force (relative L2) and the surface displacement (relative RMS) within "
                         "this fraction of the exact model's: era and balanced, the order (25, 50, "
                         "... up to --order); representatives, theta (0.5, 0.6, ... 1; --theta "
                         "ignored)")
      ->check(CLI::Range(1e-12, 0.999));
    compress->add_option("--scene", ca->scene, "with --tolerance: the scene the model is for (its probes run in closed loop)")
      ->check(CLI::ExistingFile);
    compress->add_option("--theta", ca->o.theta, "correlation threshold in (0, 1]")
      ->capture_default_str()
      ->check(CLI::Range(1e-6, 1.0));
    compress->add_option("--blend", ca->o.blend,
                         "representatives blended per waveform: 1 = plain substitution (the "
                         "seed's), 2..4 = interpolation among nearby ones")
      ->capture_default_str()
      ->check(CLI::Range(1u, 4u));
    compress->add_option("--max-delay", ca->o.max_delay, "largest delay searched, steps")
      ->capture_default_str()
      ->check(CLI::Range(0u, 65535u));
    compress->add_option("--candidates", ca->o.candidates,
                         "nearest representatives searched per waveform")
      ->capture_default_str()
      ->check(CLI::Range(1u, 100000u));
    compress->add_option("--threads", ca->o.threads, "worker threads (0: all cores)")
      ->capture_default_str()
      ->check(CLI::Range(0u, 1024u));
    compress->add_option("--noise", ca->noise,
                         "era: identify from H plus Gaussian noise of this standard deviation, "
                         "as a fraction of H's largest entry (a stand-in for measured responses; "
                         "the file says so)")
      ->check(CLI::Range(0.0, 1.0));
    compress->add_option("--seed", ca->noise_seed, "with --noise: the generator's seed")
      ->capture_default_str();
    compress->add_flag("--quiet", ca->quiet, "no progress on stderr");
    return {compress, [ca] { return run_compress(*ca); }};
  }
} // namespace irdm::cli
