// Google Benchmark of the reduced nonlinear model's deformation step (irdm/reduced_nonlinear.h):
// a rigid plane pressing into the top of the body, its depth going sinusoidally between 0 and
// DEPTH with a period of 0.2 s, so that every step has contact and a moving plane; each
// repetition times the same steps, one period after the first quarter (a faster step must not
// be timed over another part of the press). Newton's
// method with the body's tangent at every iteration beside the modified Newton method that
// keeps it (the runtime's default), the latter with a stop 100 times looser, with each of
// two of its savings undone (the planes' tangent made at every residual and a factorization at
// every iteration; U's rows and the tangent in double), and with its tangent made over
// TANGENT_STEPS steps instead of inside the step that asks for it; the ratios, each one's
// iterations, tangent evaluations and factorizations per step, and its slowest step are
// printed at the end, side by side in one run. Then the tangent's U^T (K U) alone at
// the model's size (its cubature vertices' rows, r wide; random rows): the float kernel the
// step takes beside Eigen's float product in slices (the route before it), with each one's
// multiply-adds per nanosecond.
//
//   irdm_reduced_kernels REDUCED_MODEL.h5 [DEPTH_M [TANGENT_STEPS]] [google-benchmark flags]
// REDUCED_MODEL.h5: irdm precompute SCENE --reduced (docs/reduced-model.md); DEPTH_M default
// 0.005 (m); TANGENT_STEPS default 8.
#include <irdm/reduced_nonlinear.h>
#include <irdm_common/error.h>

#include <benchmark/benchmark.h>

#include "tangent_product.h"
#include "time_collector.h"

#include <Eigen/Dense>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <memory>
#include <random>
#include <set>
#include <vector>
#include <string>

namespace
{
  std::unique_ptr<irdm::ReducedNonlinearModel> g_model;
  double                                       g_depth = 0.005;
  unsigned                                     g_tangent_steps = 8;
  constexpr double                             period  = 0.2; // s, of the press

  struct Counts
  {
    double state_sum = 0; // the sum of the last step's coordinates: where two builds' (or two
                          // variants') agree to the last digit, they took the same steps
    double iterations = 0, tangents = 0, staged = 0, factorizations = 0;
    double slowest_us = 0; // the slowest timed step
  };
  constexpr int n_variants = 6;
  Counts        g_counts[n_variants];

  /// The plane `depth` into the top of the body, pushing down.
  irdm::ReducedPlane
  top_plane(const double depth)
  {
    double top = -INFINITY;
    for (const auto &x : g_model->coordinates)
      top = std::max(top, x[2]);
    irdm::ReducedPlane p;
    p.normal = {0, 0, -1};
    p.point  = {0, 0, top - depth};
    return p;
  }

  void
  run(benchmark::State &state, const int variant)
  {
    // 0: Newton; 1: the kept tangent; 2: the kept tangent and a looser stop; 3: the kept
    // tangent, the planes' tangent and the factorization made every time; 4: the kept
    // tangent, U's rows in double; 5: the kept tangent made over g_tangent_steps steps.
    irdm::ReducedBodyOptions o;
    o.reuse_tangent = variant > 0;
    if (variant == 2)
      o.tolerance = 1e-6;
    o.keep_factorization    = variant != 3;
    o.single_precision_rows = variant != 4;
    if (variant == 5)
      o.tangent_steps = g_tangent_steps;
    irdm::ReducedNonlinearBody body(*g_model, o);
    const double               tau = g_model->time_step;
    long                       n   = 0;
    const auto                 step = [&] {
      const double depth = 0.5 * g_depth * (1 - std::cos(2 * M_PI * tau * double(++n) / period));
      const irdm::ReducedPlane plane = top_plane(depth);
      body.step(&plane, 1);
    };
    // A quarter period first: the plane in contact and moving.
    while (tau * double(n) < period / 4)
      step();
    const unsigned long tangents0 = body.tangent_evaluations(), staged0 = body.staged_tangent_evaluations(),
                        factorizations0 = body.factorizations();
    long                steps = 0, iterations = 0;
    double              slowest = 0;
    for (auto _ : state)
      {
        const auto t0 = std::chrono::steady_clock::now();
        step();
        slowest = std::max(slowest, std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - t0).count());
        iterations += body.newton_iterations();
        ++steps;
        benchmark::ClobberMemory();
      }
    Counts &c    = g_counts[variant];
    c.state_sum  = body.coordinates().sum();
    c.iterations = double(iterations) / double(std::max(steps, 1L));
    c.tangents   = double(body.tangent_evaluations() - tangents0) / double(std::max(steps, 1L));
    c.staged     = double(body.staged_tangent_evaluations() - staged0) / double(std::max(steps, 1L));
    c.slowest_us = slowest;
    c.factorizations = double(body.factorizations() - factorizations0) / double(std::max(steps, 1L));
    state.counters["iterations"] = c.iterations;
    state.counters["tangents"]   = c.tangents;
    state.counters["factorizations"] = c.factorizations;
    state.counters["failed"]     = double(body.failed_steps());
    state.counters["slowest_us"] = slowest;
  }

  std::size_t g_cubature_rows = 0; // 3 per cubature vertex

  /// U^T (K U)'s lower triangle over the cubature's rows, random A and B of the model's size:
  /// the float kernel (kernel) or Eigen's float product in the slices the step took before it.
  void
  tangent_product(benchmark::State &state, const bool kernel)
  {
    using RowMatrixF  = Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
    const auto    M   = static_cast<Eigen::Index>(g_model->size);
    const auto    n   = static_cast<Eigen::Index>(g_cubature_rows);
    std::mt19937  gen(3);
    std::uniform_real_distribution<float> dist(-1, 1);
    RowMatrixF      A(n, M), B(n, M), lower(M, M);
    Eigen::MatrixXf lower_eigen(M, M); // column-major, as the step's was
    for (RowMatrixF *X : {&A, &B})
      for (Eigen::Index k = 0; k < X->size(); ++k)
        X->data()[k] = dist(gen);
    const Eigen::Index slice = std::max<Eigen::Index>(3, (96 * 1024 / 8) / (M + 16) / 3 * 3);
    for (auto _ : state)
      {
        if (kernel)
          {
            lower.setZero();
            irdm::detail::lower_transposed_product(A.data(), B.data(), std::size_t(n), std::size_t(M), lower.data());
            benchmark::DoNotOptimize(lower.data());
          }
        else
          {
            lower_eigen.setZero();
            for (Eigen::Index c = 0; c < n; c += slice)
              {
                const Eigen::Index s = std::min(slice, n - c);
                lower_eigen.triangularView<Eigen::Lower>() += A.middleRows(c, s).transpose() * B.middleRows(c, s);
              }
            benchmark::DoNotOptimize(lower_eigen.data());
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
      std::fprintf(stderr, "Usage: irdm_reduced_kernels REDUCED_MODEL.h5 [DEPTH_M [TANGENT_STEPS]] [benchmark flags]\n"
                           "REDUCED_MODEL.h5: irdm precompute SCENE --reduced; DEPTH_M: the top\n"
                           "press's largest depth (m, default 0.005); TANGENT_STEPS: the steps a\n"
                           "tangent is made over in the last step variant (default 8)\n");
      return argc < 2 ? 2 : 0;
    }
  try
    {
      if (argc > 2)
        g_depth = std::stod(argv[2]);
      if (!(g_depth > 0 && g_depth < 1))
        throw irdm::InputError("DEPTH_M must be in (0, 1) m");
      if (argc > 3)
        {
          const long n = std::stol(argv[3]);
          if (n < 1 || n > 1000)
            throw irdm::InputError("TANGENT_STEPS must be 1 to 1000");
          g_tangent_steps = static_cast<unsigned>(n);
        }
      g_model = std::make_unique<irdm::ReducedNonlinearModel>(irdm::load_reduced_nonlinear_model(argv[1]));
    }
  catch (const std::exception &e)
    {
      std::fprintf(stderr, "irdm_reduced_kernels: error: %s\n", e.what());
      return 2;
    }
  const char *names[n_variants] = {"step, Newton", "step, kept tangent", "step, kept tangent, stop 1e-6",
                                   "step, kept tangent, factorized every iteration",
                                   "step, kept tangent, rows in double", "step, kept tangent, made over steps"};
  const auto period_steps = static_cast<benchmark::IterationCount>(std::lround(period / g_model->time_step));
  for (int v = 0; v < n_variants; ++v)
    benchmark::RegisterBenchmark(names[v], [v](benchmark::State &s) { run(s, v); })
      ->Unit(benchmark::kMicrosecond)
      ->Iterations(std::max<benchmark::IterationCount>(period_steps, 1));
  // The cubature's distinct vertices: a residual's products take 3 rows of U each.
  std::set<unsigned> cubature_vertices;
  for (const unsigned e : g_model->cubature_elements)
    cubature_vertices.insert(g_model->tetrahedra[e].begin(), g_model->tetrahedra[e].end());
  g_cubature_rows = 3 * cubature_vertices.size();
  const char *product_names[2] = {"tangent U^T (K U), Eigen float product in slices",
                                  "tangent U^T (K U), float kernel"};
  for (int k = 0; k < 2; ++k)
    benchmark::RegisterBenchmark(product_names[k], [k](benchmark::State &s) { tangent_product(s, k == 1); })
      ->Unit(benchmark::kMicrosecond);
  irdm_bench::TimeCollector collector;
  benchmark::RunSpecifiedBenchmarks(&collector);
  std::printf("\nreduced model: r = %u, %zu of %zu elements (%zu vertices), tau = %g s, top press to %g m, "
              "tangent made over %u steps in the last variant\n",
              g_model->size, g_model->cubature_elements.size(), g_model->tetrahedra.size(),
              cubature_vertices.size(), g_model->time_step, g_depth, g_tangent_steps);
  // Each run (repetitions included) by its variant: the longest name it begins with.
  const auto variant = [&](const std::string &name) {
    int v = -1;
    for (int k = 0; k < n_variants; ++k)
      if (name.rfind(names[k], 0) == 0 && (v < 0 || std::string(names[k]).size() > std::string(names[v]).size()))
        v = k;
    return v;
  };
  double newton = 0;
  for (const auto &[name, us] : collector.times)
    if (variant(name) == 0 && newton == 0)
      newton = us;
  for (const auto &[name, us] : collector.times)
    if (const int v = variant(name); v >= 0)
      std::printf("  %-46s %9.1f us  ratio to Newton %.3f  %.2f iterations, %.2f tangents (%.2f made over steps), %.2f factorizations per step, slowest %.0f us\n",
                  names[v], us, newton > 0 ? us / newton : 0.0, g_counts[v].iterations, g_counts[v].tangents,
                  g_counts[v].staged, g_counts[v].factorizations, g_counts[v].slowest_us);
  for (int v = 0; v < n_variants; ++v)
    std::printf("  %-46s the last step's coordinates sum to %.17g\n", names[v], g_counts[v].state_sum);
  // The lower triangle's multiply-adds (its tiles across the diagonal do a little more).
  const double fmas = double(g_cubature_rows) * g_model->size * (g_model->size + 1) / 2;
  for (const auto &[name, us] : collector.times)
    for (const char *p : product_names)
      if (name.rfind(p, 0) == 0)
        std::printf("  %-50s %9.1f us  %.1f million multiply-adds, %.1f per ns\n", p, us, fmas / 1e6,
                    fmas / (us * 1e3));
  return 0;
}
