// Google Benchmark of the IRDM runtime kernels on a real model: one haptic step (force loop)
// and one full surface update, for the direct convolution, representative waveforms (plain and
// interpolated) and the modal realization. Every kernel's time is also given as a ratio to the
// direct convolution's, measured in the same run (printed and written as Markdown).
//
//   irdm_kernels MODEL.h5 [REPORT.md] [google-benchmark flags]
// MODEL.h5: a model from 'irdm precompute' (scripts/benchmark.sh makes one: the press scene's
// inputs, every surface vertex out, T = 500, float, like the full cat model).
#include <irdm_common/files.h>
#include <irdm_common/report_stamp.h>
#include <irdm/modal_model.h>
#include <irdm/point_interaction.h>
#include <irdm/representative_interaction.h>
#include <irdm/representative_model.h>
#include <irdm_common/error.h>

#include "surface_product.h"

#include <benchmark/benchmark.h>

#include "time_collector.h"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <memory>

namespace
{
  std::unique_ptr<irdm::ImpulseResponseModel> g_model;
  std::map<std::string, std::unique_ptr<irdm::RepresentativeModel>> g_rep;
  std::map<unsigned, std::unique_ptr<irdm::ModalModel>>             g_modal;

  // A probe held on the first triangle the model can touch, pressing with a slow sine, so that
  // the force history is full and nonzero: the steady state of a haptic press.
  irdm::ProbeTarget
  probe_at(const irdm::ModelFrame &m, const long long n)
  {
    irdm::ProbeTarget p;
    for (int t = 0; t < static_cast<int>(m.triangles.size()); ++t)
      {
        bool ok = true;
        for (const unsigned v : m.triangles[t])
          ok = ok && m.output_input_index[v] >= 0;
        if (ok)
          {
            p.triangle = t;
            break;
          }
      }
    p.weights      = {0.5, 0.3, 0.2};
    p.displacement = {0, 0, -0.01 * (1 - std::cos(2 * M_PI * n * m.time_step))};
    return p;
  }

  // What one benchmark iteration does: a force loop step, a step and then a full surface
  // update, or the surface update alone (the deformation thread's work, the state held).
  enum class Work
  {
    step,
    step_and_surface,
    surface
  };

  template <class Interaction, class Model>
  void
  run(benchmark::State &state, const Model &m, const Work work)
  {
    Interaction         irdm(m);
    std::vector<double> u(m.n_outputs);
    long long           n = 0;
    for (; n < m.length + 70; ++n) // fill the history window (and the delay span)
      {
        const auto p = probe_at(m, n);
        irdm.step(&p, 1);
      }
    for (auto _ : state)
      {
        if (work != Work::surface)
          {
            const auto p = probe_at(m, n++);
            irdm.step(&p, 1);
          }
        if (work != Work::step)
          {
            irdm.surface_displacement(u.data());
            benchmark::DoNotOptimize(u.data());
          }
        benchmark::ClobberMemory();
      }
  }
} // namespace

int
main(int argc, char **argv)
{
  benchmark::Initialize(&argc, argv);
  if (argc < 2 || std::string(argv[1]) == "--help")
    {
      std::fprintf(stderr, "Usage: irdm_kernels MODEL.h5 [REPORT.md] [benchmark flags]\n");
      return argc < 2 ? 2 : 0;
    }
  const std::string report = argc > 2 ? argv[2] : "";
  try
    {
      g_model = std::make_unique<irdm::ImpulseResponseModel>(irdm::load_model(argv[1]));
      const auto &m = *g_model;
      for (const auto &[name, blend, theta] :
           {std::tuple<const char *, unsigned, double>{"representatives theta 0.90", 1, 0.90},
            {"representatives theta 0.99", 1, 0.99},
            {"interpolated theta 0.90 blend 3", 3, 0.90}})
        {
          irdm::CompressionOptions o;
          o.theta = theta;
          o.blend = blend;
          g_rep[name] = std::make_unique<irdm::RepresentativeModel>(irdm::compress(m, o));
        }
      for (const unsigned M : {25u, 100u})
        if (M <= m.modes.n_modes)
          g_modal[M] = std::make_unique<irdm::ModalModel>(irdm::make_modal_model(m, {M}));
    }
  catch (const std::exception &e)
    {
      std::fprintf(stderr, "irdm_kernels: error: %s\n", e.what());
      return 2;
    }
  for (const Work work : {Work::step, Work::step_and_surface, Work::surface})
    {
      const std::string what = work == Work::step               ? "force loop step/"
                               : work == Work::step_and_surface ? "step + full surface update/"
                                                                : "full surface update alone/";
      benchmark::RegisterBenchmark((what + "direct convolution").c_str(), [=](benchmark::State &s) {
        run<irdm::PointInteraction>(s, *g_model, work);
      });
      for (const auto &[name, model] : g_rep)
        {
          const irdm::RepresentativeModel *c = model.get();
          benchmark::RegisterBenchmark((what + name).c_str(), [=](benchmark::State &s) {
            run<irdm::RepresentativeInteraction>(s, *c, work);
          });
        }
      for (const auto &[M, model] : g_modal)
        {
          const irdm::ModalModel *mm = model.get();
          benchmark::RegisterBenchmark((what + "modal M " + std::to_string(M)).c_str(),
                                       [=](benchmark::State &s) { run<irdm::ModalInteraction>(s, *mm, work); });
        }
    }
  // The modal surface update's product u = Phi_M a alone, with each kernel the runtime has
  // (surface_product.h), on the same shapes: the SIMD kernel's gain measured side by side.
  // "cold": before each product (untimed) 64 MB are written, which evicts Phi_M from every
  // cache level, as in the real-time deformation thread that sleeps between updates.
  static std::vector<char> evict(std::size_t(64) << 20);
  for (const auto &[M, model] : g_modal)
    {
      const irdm::ModalModel *mm = model.get();
      using Kernel = void (*)(const float *, std::size_t, std::size_t, const double *, double *);
      const auto product = [mm](benchmark::State &s, const Kernel kernel, const bool cold) {
        std::vector<double> a(mm->surface_modes), u(mm->n_outputs);
        for (size_t i = 0; i < a.size(); ++i)
          a[i] = std::sin(1.0 + static_cast<double>(i));
        char pass = 0;
        for (auto _ : s)
          {
            if (cold)
              {
                std::fill(evict.begin(), evict.end(), ++pass);
                benchmark::DoNotOptimize(evict.data());
                benchmark::ClobberMemory();
              }
            const auto t0 = std::chrono::steady_clock::now(); // the product alone (manual time)
            kernel(mm->shapes.data(), mm->surface_modes, mm->n_outputs, a.data(), u.data());
            benchmark::DoNotOptimize(u.data());
            benchmark::ClobberMemory();
            s.SetIterationTime(
              std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
          }
      };
      const std::string tag = " M " + std::to_string(M);
      // A cold product costs about 3 ms of eviction for tens of microseconds timed, so
      // Google Benchmark's minimum time (of manual time) would take minutes: a fixed 400
      // products instead (a second or two each).
      const auto setup = [](benchmark::internal::Benchmark *b, const bool cold) {
        b->UseManualTime();
        if (cold)
          b->Iterations(400);
      };
      for (const bool cold : {false, true})
        {
          const std::string c = cold ? " cold" : "";
          std::vector<std::pair<std::string, Kernel>> kernels = {
            {"portable (build flags)", irdm::detail::surface_product_portable}};
          if (irdm::detail::surface_product_avx2_available())
            {
              kernels.emplace_back("AVX2 FMA", irdm::detail::surface_product_avx2);
              kernels.emplace_back("AVX2 FMA single precision (the runtime's)",
                                   irdm::detail::surface_product_avx2_single);
            }
          for (const auto &[name, kernel] : kernels)
            setup(benchmark::RegisterBenchmark(("Phi_M a product/" + name + tag + c).c_str(),
                                               [=, k = kernel](benchmark::State &s) { product(s, k, cold); }),
                  cold);
        }
    }
  irdm_bench::TimeCollector collector;
  benchmark::RunSpecifiedBenchmarks(&collector);

  // Each group's baseline: the direct convolution, or for the product the portable kernel
  // at the same M (the group is the name up to the mode count then).
  const auto group = [](const std::string &name) {
    const auto p = name.find("product/");
    return p == std::string::npos ? name.substr(0, name.find('/'))
                                  : name.substr(0, p) + name.substr(name.rfind(" M "));
  };
  std::map<std::string, double> direct;
  for (const auto &[name, ns] : collector.times)
    if (name.find("direct convolution") != std::string::npos ||
        name.find("portable") != std::string::npos)
      direct[group(name)] = ns;
  std::string md = "| kernel | time per call (us) | ratio to the baseline |\n|---|---|---|\n";
  for (const auto &[name, ns] : collector.times)
    {
      char        line[256];
      const auto  d = direct.find(group(name));
      std::snprintf(line, sizeof line, "| %s | %.2f | %s |\n", name.c_str(), ns / 1e3,
                    d == direct.end() ? "- (baseline not run)" : std::to_string(ns / d->second).substr(0, 6).c_str());
      md += line;
    }
  const auto &m = *g_model;
  char        head[768];
  std::snprintf(head, sizeof head,
                "# IRDM runtime kernels (Google Benchmark, one core)\n\n%s\n\nModel: %u inputs x %u "
                "outputs x T = %u (%s), one probe pressing with a slow sine, steady state (the "
                "history window full). Ratios are to the direct convolution of the same kernel "
                "(for the product u = Phi_M a of the modal surface update: to the portable "
                "kernel at the same M), measured in this run.\n\n",
                irdm::report_stamp().c_str(), m.n_inputs, m.n_outputs, m.length,
                m.double_storage ? "double" : "float");
  std::printf("\n%s%s", head, md.c_str());
  if (!report.empty())
    irdm::write_text_file(report, std::string(head) + md);
  benchmark::Shutdown();
  return 0;
}
