// Google Benchmark of many-vertex plane contact (irdm/vertex_contact.h): one force-loop step
// with exactly C candidate vertices (C = 25, 50, 100, 200), from the modal model (every mode
// in the force loop) and the direct model (to C = 100: its history costs T x inputs per row),
// and the full surface update after it.
//
//   irdm_plane_kernels VERTEX_MODEL.h5 [REPORT.md] [google-benchmark flags]
// VERTEX_MODEL.h5: every free surface vertex an input and an output (irdm validate-planes
// makes it as --vertex-model; 'irdm precompute' of a scene without model inputs/outputs).
//
// The scene: a rigid wall along d = (0, 1, 0) (the cat's side) held where exactly C free
// vertices lie within the candidate margin (5 mm) of it; it presses the deepest of them by the
// rest of the margin. The wall moves in over 100 steps and is then held; the history window
// fills (T steps) before timing, so the steps timed are the steady state of holding a wall,
// with the contact set changing as the body rings. C counts the undeformed places; the modal
// model's contact also takes a vertex the deformation carried within the margin
// (irdm/vertex_contact.h), so its steps may have a few more rows.
#include <irdm/modal_model.h>
#include <irdm/point_interaction.h>
#include <irdm_common/error.h>
#include <irdm_common/files.h>
#include <irdm_common/report_stamp.h>

#include <benchmark/benchmark.h>

#include <algorithm>
#include <cstdio>
#include <functional>
#include <memory>
#include <string>

namespace
{
  std::unique_ptr<irdm::ImpulseResponseModel> g_model;
  std::unique_ptr<irdm::ModalModel>           g_modal;
  constexpr double                            margin = 0.005; // m, the default

  /// The wall position w (along d = (0, 1, 0); the wall occupies y > w) with exactly C
  /// candidates: w - margin halfway between the C-th and (C + 1)-th largest y of the vertices
  /// that can touch.
  double
  wall_for(const irdm::ModelFrame &m, const unsigned C)
  {
    std::vector<double> y;
    for (unsigned v = 0; v < m.n_outputs / 3; ++v)
      if (m.output_input_index[v] >= 0)
        y.push_back(m.output_coordinates[v][1]);
    if (y.size() <= C)
      throw irdm::InputError("the model has only " + std::to_string(y.size()) +
                             " contact vertices; " + std::to_string(C) + " candidates asked");
    std::sort(y.rbegin(), y.rend());
    return 0.5 * (y[C - 1] + y[C]) + margin;
  }

  struct StepStats
  {
    double active = 0, candidates = 0, rounds_max = 0;
  };

  irdm::ModalInteraction
  make(const irdm::ModalModel &m, const irdm::VertexContactOptions &o)
  {
    return irdm::ModalInteraction(m, o);
  }
  irdm::PointInteraction
  make(const irdm::ImpulseResponseModel &m, const irdm::VertexContactOptions &o)
  {
    return irdm::PointInteraction(m, 0, o); // every tap: the exact model
  }

  template <class Interaction, class Model>
  void
  run(benchmark::State &state, const Model &m, const bool surface)
  {
    const unsigned             C = static_cast<unsigned>(state.range(0));
    const double               w = wall_for(m, C);
    irdm::VertexContactOptions o;
    o.margin         = margin;
    o.max_candidates = 512;
    Interaction         irdm = make(m, o);
    std::vector<double> u(m.n_outputs);
    irdm::PlaneTarget   wall;
    wall.normal = {0, -1, 0};
    // Moves in from first touch (w0: the highest vertex) to w over 100 steps, then held.
    double w0 = -1e300;
    for (unsigned v = 0; v < m.n_outputs / 3; ++v)
      if (m.output_input_index[v] >= 0)
        w0 = std::max(w0, m.output_coordinates[v][1]);
    long long n = 0;
    for (; n < m.length + 100; ++n)
      {
        wall.point = {0, w0 + (w - w0) * std::min(1.0, n / 100.0), 0};
        if (!irdm.step(&wall, 1))
          {
            state.SkipWithError("the contact step failed");
            return;
          }
      }
    if (irdm.vertex_contact().candidates() != static_cast<int>(C))
      {
        state.SkipWithError("candidate count differs from the one asked");
        return;
      }
    StepStats s;
    long long steps = 0;
    for (auto _ : state)
      {
        irdm.step(&wall, 1);
        if (surface)
          {
            irdm.surface_displacement(u.data());
            benchmark::DoNotOptimize(u.data());
          }
        benchmark::ClobberMemory();
        state.PauseTiming();
        s.active += irdm.vertex_contact().plane(0).active;
        s.candidates += irdm.vertex_contact().candidates();
        s.rounds_max = std::max<double>(s.rounds_max, irdm.vertex_contact().rounds());
        ++steps;
        state.ResumeTiming();
      }
    state.counters["candidates"] = s.candidates / std::max(1LL, steps);
    state.counters["active"]     = s.active / std::max(1LL, steps);
    state.counters["rounds_max"] = s.rounds_max;
  }

  class Collector : public benchmark::ConsoleReporter
  {
  public:
    struct Row
    {
      std::string name;
      double      us, candidates, active, rounds; // us: the benchmarks' unit
    };
    std::vector<Row> rows;
    void
    ReportRuns(const std::vector<Run> &runs) override
    {
      for (const auto &r : runs)
        if (r.run_type == Run::RT_Iteration && !r.error_occurred)
          {
            const auto get = [&](const char *k) {
              const auto i = r.counters.find(k);
              return i == r.counters.end() ? 0.0 : static_cast<double>(i->second);
            };
            rows.push_back({r.benchmark_name(), r.GetAdjustedRealTime(), get("candidates"),
                            get("active"), get("rounds_max")});
          }
      ConsoleReporter::ReportRuns(runs);
    }
  };
} // namespace

int
main(int argc, char **argv)
{
  benchmark::Initialize(&argc, argv);
  if (argc < 2 || std::string(argv[1]) == "--help")
    {
      std::fprintf(stderr, "Usage: irdm_plane_kernels VERTEX_MODEL.h5 [REPORT.md] [benchmark flags]\n"
                           "VERTEX_MODEL.h5: every free surface vertex an input and an output "
                           "(irdm validate-planes --vertex-model makes one)\n");
      return argc < 2 ? 2 : 0;
    }
  const std::string report = argc > 2 ? argv[2] : "";
  try
    {
      g_model = std::make_unique<irdm::ImpulseResponseModel>(irdm::load_model(argv[1]));
      if (g_model->n_inputs != g_model->n_outputs)
        throw irdm::InputError(std::string("'") + argv[1] + "' is not an every-surface-vertex "
                               "model (inputs differ from outputs)");
      g_modal = std::make_unique<irdm::ModalModel>(irdm::make_modal_model(*g_model, {100}));
    }
  catch (const std::exception &e)
    {
      std::fprintf(stderr, "irdm_plane_kernels: error: %s\n", e.what());
      return 2;
    }
  const std::vector<int64_t> counts = {25, 50, 100, 200};
  for (const bool surface : {false, true})
    {
      const std::string what = surface ? "step + full surface update/" : "force loop step/";
      benchmark::RegisterBenchmark((what + "modal").c_str(), [=](benchmark::State &s) {
        run<irdm::ModalInteraction>(s, *g_modal, surface);
      })->ArgsProduct({std::vector<int64_t>(counts)})->Unit(benchmark::kMicrosecond);
      benchmark::RegisterBenchmark((what + "direct").c_str(), [=](benchmark::State &s) {
        run<irdm::PointInteraction>(s, *g_model, surface);
      })->ArgsProduct({std::vector<int64_t>(counts.begin(), counts.end() - 1)})->Unit(benchmark::kMicrosecond);
    }
  Collector collector;
  benchmark::RunSpecifiedBenchmarks(&collector);

  const auto &m = *g_model;
  char        head[1024];
  std::snprintf(head, sizeof head,
                "# Many-vertex plane contact step (Google Benchmark, one core)\n\n%s\n\n"
                "Model: %u surface vertices in and out, T = %u (%s), %u modes (all in the modal "
                "force loop, %u in its surface update). One rigid wall on the cat's side held "
                "where exactly C vertices are candidates (margin %.0f mm), after the history "
                "window filled. Generated by `benchmarks/plane_kernels.cc` "
                "(`scripts/benchmark.sh`).\n\n",
                irdm::report_stamp().c_str(), m.n_inputs / 3, m.length,
                m.double_storage ? "double" : "float", g_modal->n_modes,
                g_modal->surface_modes, 1e3 * margin);
  std::string md = "| kernel / candidates | time per step (us) | candidates | mean active | "
                   "most solver rounds |\n|---|---|---|---|---|\n";
  for (const auto &r : collector.rows)
    {
      char line[256];
      std::snprintf(line, sizeof line, "| %s | %.1f | %.0f | %.1f | %.0f |\n", r.name.c_str(),
                    r.us, r.candidates, r.active, r.rounds);
      md += line;
    }
  std::printf("\n%s%s", head, md.c_str());
  if (!report.empty())
    irdm::write_text_file(report, std::string(head) + md);
  benchmark::Shutdown();
  return 0;
}
