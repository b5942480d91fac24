// IRDM precompute and runtime against the reference FEM on a small mesh: the modal route equals
// stepping the FEM itself; untruncated IRDM reproduces the FEM's probe force and surface to
// round-off; the model loader rejects bad files; mpirun -np 2 gives the serial file's numbers.
#include <irdm/irdm.h>
#include <irdm/modal_model.h>
#include <irdm/model.h>
#include <irdm/point_interaction.h>
#include <irdm/reduced_force_loop.h>
#include <irdm/reduced_nonlinear.h>
#include <irdm/vertex_contact.h>
#include <irdm_common/error.h>
#include <irdm_common/geometry.h>
#include <irdm_common/h5.h>
#include <irdm_common/neo_hookean_tet.h>
#include <reference_fem/elastodynamics.h>
#include <reference_fem/impulse_response.h>
#include <reference_fem/reduced_model.h>

#include <gtest/gtest.h>

#include "irdm_test_util.h"
#include "element_forces.h"
#include "surface_product.h"
#include "tangent_product.h"

#include <cmath>
#include <limits>
#include <numeric>
#include <set>
#include <cstdlib>
#include <filesystem>
#include <new>
#include <fstream>
#include <iostream>
#include <map>
#include <memory>
#include <random>

namespace fs = std::filesystem;
using namespace irdm;
using namespace irdm_test;

// Counts heap allocations while armed (irdm_test_util.h): the haptic step must make none.
// Eigen's temporaries come from malloc, not operator new: the link wraps malloc, calloc and
// realloc (tests/CMakeLists.txt, -Wl,--wrap) for every object linked into this program, the
// runtime library's included, so both routes are counted.
bool g_count_allocations = false;
long g_allocations       = 0;
long g_new_allocations   = 0; // of them, through operator new (the control below)
extern "C"
{
  void *__real_malloc(std::size_t n);
  void *__real_calloc(std::size_t n, std::size_t size);
  void *__real_realloc(void *p, std::size_t n);
  void *
  __wrap_malloc(std::size_t n)
  {
    if (g_count_allocations)
      ++g_allocations;
    return __real_malloc(n);
  }
  void *
  __wrap_calloc(std::size_t n, std::size_t size)
  {
    if (g_count_allocations)
      ++g_allocations;
    return __real_calloc(n, size);
  }
  void *
  __wrap_realloc(void *p, std::size_t n)
  {
    if (g_count_allocations)
      ++g_allocations;
    return __real_realloc(p, n);
  }
}
void *
operator new(std::size_t n)
{
  // Counted in malloc; here too, to tell the two routes apart.
  if (g_count_allocations)
    ++g_new_allocations;
  if (void *p = std::malloc(n ? n : 1))
    return p;
  throw std::bad_alloc();
}
void
operator delete(void *p) noexcept
{
  std::free(p);
}
void
operator delete(void *p, std::size_t) noexcept
{
  std::free(p);
}
// The array forms too: otherwise, under AddressSanitizer, memory from this operator new (malloc)
// reaches the sanitizer's own operator delete[] and is reported as an alloc-dealloc mismatch.
void *
operator new[](std::size_t n)
{
  return operator new(n);
}
void
operator delete[](void *p) noexcept
{
  std::free(p);
}
void
operator delete[](void *p, std::size_t) noexcept
{
  std::free(p);
}
// And the nothrow forms: std::stable_sort's buffer comes from operator new(nothrow) and goes
// back through operator delete, so both must be ours (malloc and free).
void *
operator new(std::size_t n, const std::nothrow_t &) noexcept
{
  return std::malloc(n ? n : 1);
}
void *
operator new[](std::size_t n, const std::nothrow_t &tag) noexcept
{
  return operator new(n, tag);
}
void
operator delete(void *p, const std::nothrow_t &) noexcept
{
  std::free(p);
}
void
operator delete[](void *p, const std::nothrow_t &) noexcept
{
  std::free(p);
}

namespace
{
  // For each output DoF j of the model, its index in the FEM's surface arrays
  // (r.surface_displacement[k][index[j]]), matched by node tag.
  std::vector<unsigned>
  fem_surface_index(const fem::RunResult &r, const ModelFrame &model)
  {
    std::map<long long, unsigned> at;
    for (unsigned i = 0; i < r.surface.node_tags.size(); ++i)
      at[r.surface.node_tags[i]] = i;
    std::vector<unsigned> index(model.n_outputs);
    for (unsigned j = 0; j < model.n_outputs; ++j)
      index[j] = 3 * at.at(model.output_node_tags[j / 3]) + j % 3;
    return index;
  }

  // The largest difference, relative to the largest displacement, between the model's H and
  // stepping the FEM of the beam scene with a unit force sample on each input DoF of `inputs`
  // (held during step 0, i.e. the load at t = tau, zero at 0 and 2 tau), at every output and
  // every step.
  double
  h_against_stepping(const ImpulseResponseModel &model, const std::vector<unsigned> &inputs)
  {
    double worst = 0, scale = 0;
    for (const unsigned k : inputs)
      {
        const long long tag = model.input_node_tags[k / 3];
        std::array<double, 3> dir = {0, 0, 0};
        dir[k % 3] = 1;
        const std::string load =
          R"(, "loads": [{"type": "vertex_force", "vertex": {"node_tag": )" + std::to_string(tag) +
          R"(}, "force_N": [)" + std::to_string(dir[0]) + "," + std::to_string(dir[1]) + "," +
          std::to_string(dir[2]) + R"(], "history": {"times_s": [0, 0.002, 0.004], "factors": [0, 1, 0]}}],
          "outputs": {"surface": true})";
        fem::Scene s = fem::parse_scene(beam_scene(load), ".");
        s.duration   = model.length * s.time_step;
        fem::ElasticDynamics fem(s);
        const auto           r = fem.run();
        const std::vector<unsigned> at = fem_surface_index(r, model);
        for (unsigned step = 0; step < model.length; ++step)
          for (unsigned j = 0; j < model.n_outputs; ++j)
            {
              const double fem_u = r.surface_displacement[step + 1][at[j]];
              worst = std::max(worst, std::abs(fem_u - model.h(k, step, j)));
              scale = std::max(scale, std::abs(fem_u));
            }
      }
    EXPECT_GT(scale, 0);
    return worst / scale;
  }
} // namespace

TEST(Precompute, ModalRouteEqualsSteppingTheFem)
{
  const fem::Scene     scene = fem::parse_scene(beam_scene(""), ".");
  ImpulseResponseModel model = make_model(scene, "modal.h5");
  ASSERT_GT(model.n_inputs, 6u);
  EXPECT_LT(h_against_stepping(model, {0u, 4u, model.n_inputs - 1}), 1e-9)
    << "modal H differs from stepping the FEM"; // measured 3.0e-10 (cond(K) of a slender beam)
}

// With every free surface vertex in and out, precompute computes each chunk's outputs from its
// own first input on and takes the others by reciprocity (H[s] symmetric). Many chunks (7
// inputs each, a ragged last one): the rows filled by symmetry still equal stepping the FEM,
// and H[s] is symmetric.
TEST(Precompute, ReciprocityFillsHAsSteppingTheFemWould)
{
  fem::Scene scene = fem::parse_scene(beam_scene(""), ".");
  scene.model.inputs.reset(); // every free surface vertex, as the outputs
  fem::PrecomputeOptions o;
  o.output           = tmp("reciprocity.h5");
  o.restart          = true;
  o.length           = 30;
  o.inputs_per_chunk = 7;
  fem::precompute_impulse_responses(scene, o);
  const ImpulseResponseModel model = load_model(o.output, scene.time_step);
  ASSERT_EQ(model.n_inputs, model.n_outputs);
  ASSERT_GT(model.n_inputs, 100u);
  size_t asymmetric = 0;
  for (unsigned k = 0; k < model.n_inputs; ++k)
    for (unsigned s = 0; s < model.length; s += 7)
      for (unsigned j = 0; j < k; ++j)
        asymmetric += model.h(k, s, j) != model.h(j, s, k);
  EXPECT_EQ(asymmetric, 0u);
  // The last input's row lies almost all below the diagonal (filled by symmetry); the one in
  // the middle half and half.
  EXPECT_LT(h_against_stepping(model, {model.n_inputs / 2 + 1, model.n_inputs - 1}), 1e-9);
}

// Modes whose responses have died out (damping, and generalized-alpha's dissipation of the
// modes above 1 / tau) are left out of the sum from their last significant step on. On the
// beam over 300 steps most of the GEMM goes, and H moves by no more than the bound the file
// states plus the GEMMs' own rounding (the all-modes sum in the same precision).
TEST(Precompute, ModesThatHaveDiedOutAreLeftOutWithinTheStatedBound)
{
  const fem::Scene scene = fem::parse_scene(beam_scene(""), ".");
  const auto make = [&](const bool double_storage, const bool every_mode, const std::string &name,
                        fem::PrecomputeReport *report) {
    fem::PrecomputeOptions o;
    o.output                = tmp(name);
    o.restart               = true;
    o.length                = 300;
    o.double_storage        = double_storage;
    o.every_mode_every_step = every_mode;
    *report                 = fem::precompute_impulse_responses(scene, o);
    return load_model(o.output, scene.time_step);
  };
  fem::PrecomputeReport live_d, all_d, live_f, all_f;
  const ImpulseResponseModel ld = make(true, false, "live_d.h5", &live_d);
  const ImpulseResponseModel ad = make(true, true, "all_d.h5", &all_d);
  const ImpulseResponseModel lf = make(false, false, "live_f.h5", &live_f);
  const ImpulseResponseModel af = make(false, true, "all_f.h5", &all_f);
  EXPECT_EQ(all_d.gemm_work, 1.0);
  EXPECT_LT(live_d.gemm_work, 0.5) << "rho_inf = 0.8: the high modes die within about 200 steps";
  EXPECT_LT(live_f.gemm_work, live_d.gemm_work) << "float's round-off is reached sooner";
  const auto bound = [&](const std::string &name) {
    return h5::Reader(tmp(name)).double_attribute("/impulse_response/H",
                                                  "modes_left_out_below_m_per_N");
  };
  EXPECT_EQ(bound("all_d.h5"), 0.0);
  double scale = 0, left_d = 0, left_f = 0, rounding_f = 0;
  for (unsigned k = 0; k < ad.n_inputs; ++k)
    for (unsigned s = 0; s < ad.length; ++s)
      for (unsigned j = 0; j < ad.n_outputs; ++j)
        {
          const double exact = ad.h(k, s, j);
          scale              = std::max(scale, std::abs(exact));
          left_d             = std::max(left_d, std::abs(ld.h(k, s, j) - exact));
          left_f             = std::max(left_f, std::abs(lf.h(k, s, j) - exact));
          rounding_f         = std::max(rounding_f, std::abs(af.h(k, s, j) - exact));
        }
  ASSERT_GT(scale, 0);
  // The bound is a tenth of the round-off of the largest driving-point response.
  EXPECT_GT(bound("live_d.h5"), 0.0);
  EXPECT_LT(bound("live_d.h5"), 1e-16 * scale);
  EXPECT_LT(bound("live_f.h5"), 1e-8 * scale);
  // Double: the bound plus the GEMM's rounding over about 10^3 modes.
  EXPECT_LE(left_d, bound("live_d.h5") + 1e-13 * scale);
  // Float: no worse than the all-modes float model's own rounding (twice: other sums) plus the bound.
  EXPECT_LE(left_f, 2 * rounding_f + bound("live_f.h5"));
  std::printf("[ measured ] GEMM work %.3f (double), %.3f (float); H moved by %.2e (double), "
              "%.2e (float, all modes: %.2e) of its largest entry\n",
              live_d.gemm_work, live_f.gemm_work, left_d / scale, left_f / scale,
              rounding_f / scale);
}

namespace
{
  // Runs the beam scene with one unilateral probe (its JSON fields after "name") through the
  // FEM and through untruncated IRDM (PointInteraction on the model's H, ModalInteraction on
  // its modal realization, every mode) and expects the same probe force and surface to
  // round-off (the modal surface to float round-off), with no heap allocation inside the runtimes' steps. Returns the most vertices
  // the probe's force spread over.
  int
  expect_irdm_reproduces_the_fem(const std::string &probe_fields, const std::string &name)
  {
    const std::string probe = R"(, "probes": [{"name": "finger", )" + probe_fields + R"(}],
        "outputs": {"surface": true})";
    const fem::Scene     scene = fem::parse_scene(beam_scene(probe), ".");
    ImpulseResponseModel model = make_model(scene, name + ".h5");
    fem::ElasticDynamics fem(scene);
    const auto           r = fem.run();
    const ModalModel     modal_model = make_modal_model(model, {model.modes.n_modes});

    std::vector<unsigned>                 cand;
    std::vector<std::array<unsigned, 3>> tris;
    const int sides = static_cast<int>(std::find(model.surface_names.begin(), model.surface_names.end(), "sides") -
                                       model.surface_names.begin());
    for (unsigned t = 0; t < model.triangles.size(); ++t)
      if (model.triangle_surface[t] == sides)
        cand.push_back(t), tris.push_back(model.triangles[t]);
    const std::vector<unsigned> at = fem_surface_index(r, model);

    PointInteraction    irdm(model);
    ModalInteraction    modal(modal_model);
    // The public API (irdm/irdm.h) on the same file: the coupling is the body's own.
    irdm::Body api(irdm::Model::load(tmp(name + ".h5"), {0}));
    std::vector<double> x_api(model.n_outputs);
    double              ferr_api = 0, uerr_api = 0;
    // A virtual coupling (scene key probes[].coupling): each runtime's target from its own
    // last probe displacement, as the FEM's from its own.
    const contact::Coupling coupling{scene.probes[0].coupling_stiffness,
                                     scene.probes[0].coupling_damping};
    std::array<double, 3>   u_irdm{}, u_modal{};
    std::vector<double> u(model.n_outputs), um(model.n_outputs);
    double fmax = 0, ferr = 0, umax = 0, uerr = 0, uerr_modal = 0;
    int    switches = 0, most_vertices = 0;
    bool   was_active = false;
    for (unsigned n = 0; n < scene.n_steps(); ++n)
      {
        const double t  = (n + 1) * scene.time_step;
        const auto  &p  = scene.probes[0];
        const auto   sp = geometry::closest_point(model.output_coordinates, tris, p.path.at(t));
        ProbeTarget  target;
        target.triangle = static_cast<int>(cand[sp.triangle]);
        target.weights  = sp.weights;
        if (p.radius > 0)
          target.n_patch = geometry::radius_patch(model.output_coordinates, tris, sp.point, p.radius,
                                                  target.patch_vertices.data(),
                                                  target.patch_weights.data(), contact::max_patch);
        most_vertices = std::max(most_vertices, p.radius > 0 ? target.n_patch : 3);
        std::array<double, 3> device, device_before;
        for (int d = 0; d < 3; ++d)
          {
            device[d]        = p.depth.at(t) * p.direction[d];
            device_before[d] = p.depth.at(t - scene.time_step) * p.direction[d];
          }
        target.direction    = p.direction;
        target.unilateral   = true;
        target.compliance   = coupling.compliance(scene.time_step);
        ProbeTarget target_modal = target;
        target.displacement = coupling.target(device, device_before, u_irdm, scene.time_step);
        target_modal.displacement =
          coupling.target(device, device_before, u_modal, scene.time_step);
        irdm::Probe probe_api;
        probe_api.triangle           = target.triangle;
        probe_api.weights            = target.weights;
        probe_api.n_patch            = target.n_patch;
        probe_api.patch_vertices     = target.patch_vertices;
        probe_api.patch_weights      = target.patch_weights;
        probe_api.displacement       = device;
        probe_api.coupling_stiffness = coupling.stiffness;
        probe_api.coupling_damping   = coupling.damping;
        probe_api.direction          = p.direction;
        probe_api.unilateral         = true;
        irdm::StepInput  in_api;
        irdm::StepOutput out_api;
        in_api.probes       = &probe_api;
        in_api.n_probes     = 1;
        g_count_allocations = true;
        const bool stepped  = irdm.step(&target, 1);
        irdm.surface_displacement(u.data());
        const bool stepped_modal = modal.step(&target_modal, 1);
        modal.surface_displacement(um.data());
        const bool stepped_api = api.step(in_api, out_api);
        g_count_allocations = false;
        api.surface_positions(x_api.data());
        EXPECT_TRUE(stepped_api) << api.refusal();
        u_irdm  = irdm.probe_displacement(0);
        u_modal = modal.probe_displacement(0);
        EXPECT_TRUE(stepped && stepped_modal);
        if (!stepped || !stepped_modal)
          return most_vertices;
        const auto &fem_force = r.probe_force.at("finger")[n + 1];
        for (int d = 0; d < 3; ++d)
          {
            fmax = std::max(fmax, std::abs(fem_force[d]));
            ferr = std::max({ferr, std::abs(irdm.force(0)[d] - fem_force[d]),
                             std::abs(modal.force(0)[d] - fem_force[d])});
            ferr_api = std::max(ferr_api, std::abs(out_api.probe_force[0][d] - fem_force[d]));
          }
        switches += irdm.active(0) != was_active;
        was_active = irdm.active(0);
        for (unsigned j = 0; j < model.n_outputs; ++j)
          {
            const double fem_u = r.surface_displacement[n + 1][at[j]];
            umax = std::max(umax, std::abs(fem_u));
            uerr       = std::max(uerr, std::abs(u[j] - fem_u));
            uerr_modal = std::max(uerr_modal, std::abs(um[j] - fem_u));
            uerr_api   = std::max(uerr_api, std::abs(x_api[j] - model.output_coordinates[j / 3][j % 3] - fem_u));
          }
      }
    EXPECT_EQ(g_allocations, 0) << "heap allocations inside step() / surface_displacement()";
    EXPECT_LT(ferr_api / fmax, 1e-9);
    EXPECT_LT(uerr_api / umax, 1e-5);
    EXPECT_GT(fmax, 1e-4);  // the probe did push
    EXPECT_GE(switches, 2); // it touched and let go
    EXPECT_LT(ferr / fmax, 1e-9);
    EXPECT_LT(uerr / umax, 1e-9);
    // The modal surface's shapes and static residual are stored in float (eps 6e-8, times the
    // cancellation among the modes; seen: 1.3e-6).
    EXPECT_LT(uerr_modal / umax, 1e-5);
    return most_vertices;
  }

  const std::string moving_press = R"("surface": "sides", "direction": [0, 0, -1], "unilateral": true,
      "path": {"times_s": [0, 0.2], "points_m": [[0.21, 0.001, 0.01], [0.235, -0.002, 0.01]]},
      "depth": {"times_s": [0, 0.05, 0.1, 0.12], "values_m": [0, 0.002, 0.002, -0.002]})";
} // namespace

// The patch of a radius probe on a flat, uniform triangulated grid (spacing 1): every vertex
// has the same area, so the weights are psi(|x - c| / r) normalized; vertices at or beyond r
// get none; the patch is symmetric about its centre.
TEST(Runtime, RadiusPatchWeightsOnAFlatGrid)
{
  const int                            n = 11; // vertices per side; centre vertex (5, 5)
  std::vector<geometry::Point>         v;
  std::vector<std::array<unsigned, 3>> tri;
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i)
      v.push_back({double(i), double(j), 0.0});
  for (int j = 0; j + 1 < n; ++j)
    for (int i = 0; i + 1 < n; ++i)
      {
        const unsigned a = j * n + i;
        // One diagonal direction throughout: every interior vertex is in 6 triangles of area
        // 1/2, so all have the same area (1).
        tri.push_back({a, a + 1, a + n + 1});
        tri.push_back({a, a + n + 1, a + n});
      }
  std::array<unsigned, contact::max_patch> vertex{};
  std::array<double, contact::max_patch>   weight{};
  const double                             r = 2.5;
  const int k = geometry::radius_patch(v, tri, {5, 5, 0}, r, vertex.data(), weight.data(),
                                       contact::max_patch);
  // Vertices with |x - c| < 2.5 on the unit grid: 21 (1 + 4 + 4 + 4 + 8).
  ASSERT_EQ(k, 21);
  double sum = 0, norm = 0;
  for (int i = 0; i < k; ++i)
    {
      const double rho2 = (std::pow(v[vertex[i]][0] - 5, 2) + std::pow(v[vertex[i]][1] - 5, 2)) / (r * r);
      norm += (1 - rho2) * (1 - rho2);
      sum += weight[i];
    }
  EXPECT_NEAR(sum, 1, 1e-14);
  for (int i = 0; i < k; ++i)
    {
      const double rho2 = (std::pow(v[vertex[i]][0] - 5, 2) + std::pow(v[vertex[i]][1] - 5, 2)) / (r * r);
      EXPECT_NEAR(weight[i], (1 - rho2) * (1 - rho2) / norm, 1e-14);
    }
  EXPECT_EQ(geometry::radius_patch(v, tri, {5, 5, 0}, 0.5, vertex.data(), weight.data(), 8), 1);
  EXPECT_EQ(geometry::radius_patch(v, tri, {5.5, 5.5, 0}, 0.5, vertex.data(), weight.data(), 8), 0);
  EXPECT_EQ(geometry::radius_patch(v, tri, {5, 5, 0}, r, vertex.data(), weight.data(), 20), -1);
}

// The modal surface update's product u = Phi_M a (surface_product.h): the portable kernel, the
// AVX2/FMA one and the single-precision AVX2/FMA one against a long-double sum, at sizes that
// leave every remainder (rows not a multiple of 8, modes not a multiple of 4 or 8, more modes
// than the single kernel's block of 512) and at the full cat's 1554 x 100.
TEST(Runtime, SurfaceProductKernelsAgreeWithAnExactSum)
{
  std::mt19937                           gen(7);
  std::uniform_real_distribution<double> dist(-1, 1);
  for (const auto &[nout, M] : {std::pair<size_t, size_t>{1, 1}, {7, 3}, {8, 4}, {9, 5}, {13, 25},
                                {17, 100}, {11, 1031}, {1554, 100}})
    {
      std::vector<float>  shapes(nout * M); // as ModalModel::shapes
      std::vector<double> a(M), u(nout);
      for (auto &x : shapes)
        x = static_cast<float>(dist(gen));
      for (auto &x : a)
        x = dist(gen);
      // Each row's (or, transposed, each column's) product with x in long double, and the sum
      // of its terms' magnitudes.
      const auto exact_sums = [&](const std::vector<double> &x, const bool transposed, std::vector<double> &sum,
                                  std::vector<double> &magnitude) {
        const size_t n = transposed ? M : nout, terms = transposed ? nout : M;
        sum.assign(n, 0), magnitude.assign(n, 0);
        for (size_t i = 0; i < n; ++i)
          {
            long double t = 0, g = 0;
            for (size_t k = 0; k < terms; ++k)
              {
                const long double term = static_cast<long double>(transposed ? shapes[k * M + i] : shapes[i * M + k]) * x[k];
                t += term, g += std::abs(term);
              }
            sum[i] = static_cast<double>(t), magnitude[i] = static_cast<double>(g);
          }
      };
      std::vector<double> exact, scale;
      exact_sums(a, false, exact, scale);
      // Any summation order of n terms in a precision of unit round-off r is within
      // n r (1 + O(n r)) of the sum of the magnitudes. Double: n = M. Single: a rounded to float
      // (1), the lane sums of about M / 8 FMAs per block of 512 modes, three adds across the
      // lanes, and the blocks' sums added in double.
      const double r_double = std::numeric_limits<double>::epsilon() / 2;
      const double r_single = std::numeric_limits<float>::epsilon() / 2;
      const double n_single = 1 + std::ceil(std::min<double>(M, 512) / 8) + 3 + 1;
      const auto   check    = [&](const char *kernel, const double bound) {
        for (size_t j = 0; j < nout; ++j)
          ASSERT_LE(std::abs(u[j] - exact[j]), 1.01 * bound * scale[j])
            << kernel << ", " << nout << " x " << M << ", row " << j;
      };
      detail::surface_product_portable(shapes.data(), M, nout, a.data(), u.data());
      check("portable", M * r_double);
      if (detail::surface_product_avx2_available())
        {
          std::fill(u.begin(), u.end(), 1e300); // every row must be written
          detail::surface_product_avx2(shapes.data(), M, nout, a.data(), u.data());
          check("AVX2", M * r_double);
          std::fill(u.begin(), u.end(), 1e300);
          detail::surface_product_avx2_single(shapes.data(), M, nout, a.data(), u.data());
          check("AVX2 single", n_single * r_single);
        }
      else
        std::cout << "note: no AVX2/FMA on this CPU; only the portable kernel checked\n";
      // Two products in one pass (a, and a in reverse order), summed in double: each within
      // M r of its sum of magnitudes, as the double kernels.
      const std::vector<double> b(a.rbegin(), a.rend());
      std::vector<double>       u2(nout), v2(nout), b_exact, b_scale;
      exact_sums(b, false, b_exact, b_scale);
      for (const bool avx2 : {false, true})
        {
          if (avx2 && !detail::surface_product_avx2_available())
            continue;
          std::fill(u2.begin(), u2.end(), 1e300); // every row must be written
          std::fill(v2.begin(), v2.end(), 1e300);
          (avx2 ? detail::rows_product2_avx2 : detail::rows_product2_portable)(shapes.data(), M, nout, a.data(),
                                                                               b.data(), u2.data(), v2.data());
          for (size_t j = 0; j < nout; ++j)
            {
              ASSERT_LE(std::abs(u2[j] - exact[j]), 1.01 * M * r_double * scale[j])
                << "two at once, " << (avx2 ? "AVX2" : "portable") << ", first, row " << j;
              ASSERT_LE(std::abs(v2[j] - b_exact[j]), 1.01 * M * r_double * b_scale[j])
                << "two at once, " << (avx2 ? "AVX2" : "portable") << ", second, row " << j;
            }
        }
      // The transposed product, g = rows^T f (the forces back onto the basis): summed in
      // double, so within n_rows r of the sum of the magnitudes.
      std::vector<double> f(nout), g(M), g_exact, g_scale;
      for (auto &x : f)
        x = dist(gen);
      exact_sums(f, true, g_exact, g_scale);
      const auto check_transposed = [&](const char *kernel) {
        for (size_t m = 0; m < M; ++m)
          ASSERT_LE(std::abs(g[m] - g_exact[m]), 1.01 * nout * r_double * g_scale[m])
            << kernel << ", " << nout << " x " << M << ", column " << m;
      };
      std::fill(g.begin(), g.end(), 1e300); // every entry must be written
      detail::transposed_rows_product_portable(shapes.data(), M, nout, f.data(), g.data());
      check_transposed("transposed, portable");
      if (detail::surface_product_avx2_available())
        {
          std::fill(g.begin(), g.end(), 1e300);
          detail::transposed_rows_product_avx2(shapes.data(), M, nout, f.data(), g.data());
          check_transposed("transposed, AVX2");
        }
    }
}

// The reduced tangent's two float products (tangent_product.h) against exact sums: K U by a
// block-CSR matrix of 3 x 3 blocks, and A^T B's lower triangle; every entry written, nothing
// written past the output, and each within the rounding of a float sum of its terms.
TEST(Runtime, TangentProductKernelsAgreeWithAnExactSum)
{
  std::mt19937                           gen(11);
  std::uniform_real_distribution<double> dist(-1, 1);
  const double                           r_single = std::numeric_limits<float>::epsilon() / 2;
  constexpr float                        guard    = 1e30f; // past the output: must stay
  // Widths around the kernels' vector (8), tile (16, 32) and row-chunk (128) sizes.
  for (const auto &[n_vertices, M] : {std::pair<size_t, size_t>{1, 1}, {2, 7}, {5, 8}, {7, 17}, {13, 32},
                                      {11, 45}, {60, 100}, {50, 222}})
    {
      // Block rows: each vertex coupled to itself and a few random others.
      std::vector<unsigned> row_start{0}, column;
      for (size_t i = 0; i < n_vertices; ++i)
        {
          std::set<unsigned> c{static_cast<unsigned>(i)};
          for (int k = 0; k < 5; ++k)
            c.insert(static_cast<unsigned>(gen() % n_vertices));
          column.insert(column.end(), c.begin(), c.end());
          row_start.push_back(static_cast<unsigned>(column.size()));
        }
      std::vector<double> blocks(9 * column.size());
      for (auto &x : blocks)
        x = 1e3 * dist(gen); // a stiffness's scale: the blocks are rounded to float
      std::vector<float> rows(3 * n_vertices * M);
      for (auto &x : rows)
        x = static_cast<float>(dist(gen));
      const detail::BlockRows K{blocks.data(), row_start.data(), column.data(), n_vertices};
      const size_t            n_out = 3 * n_vertices * M;
      for (const bool avx2 : {false, true})
        {
          if (avx2 && !detail::surface_product_avx2_available())
            {
              std::cout << "note: no AVX2/FMA on this CPU; only the portable kernels checked\n";
              continue;
            }
          const char *kernel = avx2 ? "AVX2" : "portable";
          // K U: each entry a float sum of 3 (blocks in the row) terms, each block entry rounded
          // to float (one more rounding each).
          std::vector<float> KU(n_out + 64, guard);
          (avx2 ? detail::block_rows_product_avx2 : detail::block_rows_product_portable)(K, rows.data(), M, KU.data());
          for (size_t i = 0; i < n_vertices; ++i)
            for (size_t a = 0; a < 3; ++a)
              for (size_t m = 0; m < M; ++m)
                {
                  long double t = 0, g = 0;
                  for (unsigned s = row_start[i]; s < row_start[i + 1]; ++s)
                    for (size_t b = 0; b < 3; ++b)
                      {
                        const long double term = static_cast<long double>(blocks[9 * s + a + 3 * b]) *
                                                 rows[(3 * column[s] + b) * M + m];
                        t += term, g += std::abs(term);
                      }
                  const double n_terms = 3.0 * (row_start[i + 1] - row_start[i]);
                  ASSERT_LE(std::abs(KU[(3 * i + a) * M + m] - static_cast<double>(t)),
                            1.01 * (n_terms + 1) * r_single * static_cast<double>(g))
                    << kernel << " K U, " << n_vertices << " vertices x " << M << ", row " << 3 * i + a << ", column " << m;
                }
          for (size_t k = n_out; k < KU.size(); ++k)
            ASSERT_EQ(KU[k], guard) << kernel << " K U wrote past its end";
          // A^T B's lower triangle, A the rows and B = K U: sums of n rows in float, in chunks
          // of 128 rows added in.
          const size_t       n = 3 * n_vertices;
          std::vector<float> lower(M * M + 64, 0.0f);
          std::fill(lower.begin() + long(M * M), lower.end(), guard);
          for (size_t i = 0; i < M; ++i)
            for (size_t j = 0; j <= i; ++j)
              lower[i * M + j] = 0.5f; // added to, not overwritten
          (avx2 ? detail::lower_transposed_product_avx2 : detail::lower_transposed_product_portable)(
            rows.data(), KU.data(), n, M, lower.data());
          for (size_t i = 0; i < M; ++i)
            for (size_t j = 0; j <= i; ++j)
              {
                long double t = 0.5L, g = 0.5L;
                for (size_t k = 0; k < n; ++k)
                  {
                    const long double term = static_cast<long double>(rows[k * M + i]) * KU[k * M + j];
                    t += term, g += std::abs(term);
                  }
                const double n_terms = double(n) + std::ceil(double(n) / 128) + 1;
                ASSERT_LE(std::abs(lower[i * M + j] - static_cast<double>(t)), 1.01 * n_terms * r_single * static_cast<double>(g))
                  << kernel << " lower, " << n << " rows x " << M << ", entry " << i << ", " << j;
              }
          for (size_t k = M * M; k < lower.size(); ++k)
            ASSERT_EQ(lower[k], guard) << kernel << " lower wrote past its end";
        }
    }
}

TEST(Runtime, UntruncatedIrdmReproducesTheFem)
{
  EXPECT_EQ(expect_irdm_reproduces_the_fem(moving_press, "exact"), 3);
}

// A device coupled to the probed point by a spring and a damper (virtual coupling, solved
// implicitly through the feed-through; issue 15), unilateral on the coupled force: the FEM
// with the same coupling, to round-off.
TEST(Runtime, UntruncatedIrdmReproducesTheFemWithAVirtualCoupling)
{
  EXPECT_EQ(expect_irdm_reproduces_the_fem(
              moving_press + R"(, "coupling": {"stiffness_N_m": 200, "damping_N_s_m": 0.5})",
              "coupled"),
            3);
}

// A probe with a contact radius (issue 16): its force spreads over every surface vertex within
// 12 mm by the smooth weights of geometry::radius_patch, in the FEM and in the runtimes alike,
// and the patch changes as the probe slides.
TEST(Runtime, UntruncatedIrdmReproducesTheFemWithARadiusProbe)
{
  EXPECT_GE(expect_irdm_reproduces_the_fem(moving_press + R"(, "radius_m": 0.012)", "radius"), 8);
}

namespace
{
  // The beam with every free surface vertex an input and an output, pressed by two planes at
  // once (issue 13): a tilted floor rises under the tip and lets go (the contact spreads over
  // the bottom vertices of the last two sections), and a wall pushes the tip face 1 mm along
  // the beam and withdraws. Runs the linear FEM (vertex contact) and untruncated IRDM from the
  // direct model and the modal model (every mode), and expects the planes' forces and the
  // surface to agree to round-off, with no heap allocation in the runtimes' steps. Returns the
  // most vertices in contact at once.
  int
  expect_vertex_contact_reproduces_the_fem(const std::string &stiffness_field, const std::string &name)
  {
    const std::string planes = R"(, "outputs": {"surface": true}, "planes": [
        {"name": "floor", "normal": [-0.2, 0, 1],
         "position": {"times_s": [0, 0.06, 0.1, 0.14], "points_m": [[0.25, 0.005, -0.001],
                      [0.25, 0.005, 0.002], [0.25, 0.005, 0.002], [0.25, 0.005, -0.004]]})" +
                               stiffness_field + R"(},
        {"name": "wall", "normal": [-1, 0, 0],
         "position": {"times_s": [0, 0.03, 0.09, 0.15], "points_m": [[0.2502, 0, 0],
                      [0.2502, 0, 0], [0.249, 0, 0], [0.2515, 0, 0]]})" +
                               stiffness_field + "}]";
    fem::Scene scene = fem::parse_scene(beam_scene(planes), ".");
    scene.model.inputs.reset(); // every free surface vertex
    ImpulseResponseModel model       = make_model(scene, name + ".h5");
    const ModalModel     modal_model = make_modal_model(model, {model.modes.n_modes});
    const auto           r           = fem::ElasticDynamics(scene).run();
    const std::vector<unsigned> at = fem_surface_index(r, model);

    PointInteraction    direct(model);
    ModalInteraction    modal(modal_model);
    // The public API (irdm/irdm.h) on the same file: the plates' coupling is the body's own.
    irdm::Body          api(irdm::Model::load(tmp(name + ".h5"), {0}));
    std::vector<double> x_api(model.n_outputs);
    double              ferr_api = 0, uerr_api = 0;
    std::vector<double> u(model.n_outputs), um(model.n_outputs);
    double fmax = 0, ferr = 0, umax = 0, uerr = 0, uerr_modal = 0, deepest = 0;
    // Device-held plates (planes[].coupling): each plate's point one step before, per runtime.
    std::array<std::array<double, 3>, 2> plate_direct, plate_modal;
    for (int p = 0; p < 2; ++p)
      plate_direct[p] = plate_modal[p] = scene.planes[p].position.at(0.0);
    const auto plate_after = [](const PlaneTarget &target, const PlaneContactResult &r) {
      std::array<double, 3> x = target.point;
      for (int d = 0; d < 3; ++d)
        x[d] -= target.coupling_compliance * r.force[d];
      return x;
    };
    int    most_active = 0, switches = 0, was_active = 0;
    for (unsigned n = 0; n < scene.n_steps(); ++n)
      {
        const double t = (n + 1) * scene.time_step;
        std::array<PlaneTarget, 2> targets, targets_modal;
        for (int p = 0; p < 2; ++p)
          {
            const auto             &pl = scene.planes[p];
            const contact::Coupling coupling{pl.coupling_stiffness, pl.coupling_damping};
            targets[p].normal              = pl.normal;
            targets[p].stiffness           = pl.vertex_stiffness;
            targets[p].coupling_compliance = coupling.compliance(scene.time_step);
            targets_modal[p]               = targets[p];
            targets[p].point       = coupling.target(pl.position.at(t), pl.position.at(t - scene.time_step),
                                                     plate_direct[p], scene.time_step);
            targets_modal[p].point = coupling.target(pl.position.at(t), pl.position.at(t - scene.time_step),
                                                     plate_modal[p], scene.time_step);
          }
        std::array<irdm::Plane, 2> planes_api;
        for (int p = 0; p < 2; ++p)
          {
            planes_api[p].normal             = scene.planes[p].normal;
            planes_api[p].point              = scene.planes[p].position.at(t);
            planes_api[p].stiffness          = scene.planes[p].vertex_stiffness;
            planes_api[p].coupling_stiffness = scene.planes[p].coupling_stiffness;
            planes_api[p].coupling_damping   = scene.planes[p].coupling_damping;
          }
        irdm::StepInput  in_api;
        irdm::StepOutput out_api;
        in_api.planes       = planes_api.data();
        in_api.n_planes     = 2;
        g_count_allocations = true;
        const bool stepped = direct.step(targets.data(), 2);
        direct.surface_displacement(u.data());
        const bool stepped_modal = modal.step(targets_modal.data(), 2);
        modal.surface_displacement(um.data());
        const bool stepped_api = api.step(in_api, out_api);
        g_count_allocations = false;
        api.surface_positions(x_api.data());
        EXPECT_TRUE(stepped_api) << api.refusal();
        for (int p = 0; p < 2; ++p)
          {
            plate_direct[p] = plate_after(targets[p], direct.vertex_contact().plane(p));
            plate_modal[p]  = plate_after(targets_modal[p], modal.vertex_contact().plane(p));
          }
        EXPECT_TRUE(stepped && stepped_modal);
        if (!stepped || !stepped_modal)
          return 0;
        int n_active = 0;
        for (int p = 0; p < 2; ++p)
          {
            const auto &fem_force = r.plane_force.at(scene.planes[p].name)[n + 1];
            for (int d = 0; d < 3; ++d)
              {
                fmax = std::max(fmax, std::abs(fem_force[d]));
                ferr = std::max({ferr, std::abs(direct.vertex_contact().plane(p).force[d] - fem_force[d]),
                                 std::abs(modal.vertex_contact().plane(p).force[d] - fem_force[d])});
                ferr_api = std::max(ferr_api, std::abs(out_api.plane_force[p][d] - fem_force[d]));
              }
            EXPECT_EQ(out_api.plane_vertices[p], modal.vertex_contact().plane(p).active);
            n_active += direct.vertex_contact().plane(p).active;
            EXPECT_EQ(direct.vertex_contact().plane(p).active, modal.vertex_contact().plane(p).active);
            EXPECT_NEAR(direct.vertex_contact().plane(p).penetration,
                        std::max(0.0, r.plane_penetration.at(scene.planes[p].name)[n + 1]), 1e-12);
            deepest = std::max(deepest, direct.vertex_contact().plane(p).penetration);
          }
        most_active = std::max(most_active, n_active);
        switches += (n_active > 0) != (was_active > 0);
        was_active = n_active;
        for (unsigned j = 0; j < model.n_outputs; ++j)
          {
            const double fem_u = r.surface_displacement[n + 1][at[j]];
            umax       = std::max(umax, std::abs(fem_u));
            uerr       = std::max(uerr, std::abs(u[j] - fem_u));
            uerr_modal = std::max(uerr_modal, std::abs(um[j] - fem_u));
            uerr_api   = std::max(uerr_api, std::abs(x_api[j] - model.output_coordinates[j / 3][j % 3] - fem_u));
          }
      }
    EXPECT_LT(ferr_api / fmax, 1e-9);
    EXPECT_LT(uerr_api / umax, 1e-5);
    std::cout << "vertex contact (" << name << "): peak force " << fmax << " N, force error "
              << ferr / fmax << ", surface error " << uerr / umax << " (modal " << uerr_modal / umax
              << "), deepest penetration " << deepest << " m, most vertices in contact "
              << most_active << "\n";
    EXPECT_EQ(g_allocations, 0) << "heap allocations inside step() / surface_displacement()";
    EXPECT_GT(fmax, 1e-3);  // the planes did push
    EXPECT_GE(switches, 2); // touched and let go
    EXPECT_LT(ferr / fmax, 1e-9);
    EXPECT_LT(uerr / umax, 1e-9);
    // The modal surface's shapes and static residual are stored in float (eps 6e-8, times the
    // cancellation among the modes; seen: 1.3e-6).
    EXPECT_LT(uerr_modal / umax, 1e-5);
    if (stiffness_field.empty() || stiffness_field.find("vertex_stiffness") == std::string::npos)
      EXPECT_LT(deepest, 1e-12); // a rigid plane (or plate) is met, not passed
    else
      EXPECT_GT(deepest, 1e-5); // a compliant one gives way
    return most_active;
  }
} // namespace

// Many-vertex contact against a floor and a wall at once, rigid.
TEST(Runtime, UntruncatedVertexContactReproducesTheFem)
{
  EXPECT_GE(expect_vertex_contact_reproduces_the_fem("", "vertex_rigid"), 6); // measured 7
}

// The same with compliant planes (20 N/m per vertex), solved implicitly in both.
TEST(Runtime, UntruncatedCompliantVertexContactReproducesTheFem)
{
  EXPECT_GE(expect_vertex_contact_reproduces_the_fem(R"(, "vertex_stiffness_N_m": 20)", "vertex_compliant"), 10); // measured 12
}

// A penalty wall (PlaneTarget::penalty, Pa/m) pushes each vertex with the penalty times the
// vertex's lumped area, as the nonlinear FEM's P1 contact (integrated at the face vertices)
// does. The lumped areas tile the model's surface (the faces of the box its free vertices
// span, all but the clamp's end: triangles with a fixed vertex are not the model's); a
// plane that touches the tip's top corner alone pushes it exactly as a plane of that vertex's
// stiffness, and measurably unlike a plane of the mean vertex's.
TEST(Runtime, PenaltyWallWeighsEachVertexByItsLumpedArea)
{
  fem::Scene scene = fem::parse_scene(beam_scene(""), ".");
  scene.model.inputs.reset(); // every free surface vertex
  const ImpulseResponseModel model = make_model(scene, "penalty_wall.h5");
  const std::vector<double>  area  = lumped_vertex_areas(model);
  ASSERT_EQ(area.size(), model.n_outputs / 3);
  // The box of the beam's free vertices (meshes/beam.geo: 0.25 x 0.01 x 0.01 m, less the
  // clamped layer).
  std::array<double, 3> lo{1e300, 1e300, 1e300}, hi{-1e300, -1e300, -1e300};
  for (const auto &X : model.output_coordinates)
    for (int d = 0; d < 3; ++d)
      lo[d] = std::min(lo[d], X[d]), hi[d] = std::max(hi[d], X[d]);
  const double length = hi[0] - lo[0], side = hi[1] - lo[1];
  ASSERT_NEAR(hi[2] - lo[2], side, 1e-12);
  const double total = std::accumulate(area.begin(), area.end(), 0.0);
  const double side_faces = 4 * length * side, tip_face = side * side;
  std::printf("lumped areas: %.12g m^2, the four sides and the tip %.12g m^2\n", total,
              side_faces + tip_face);
  EXPECT_NEAR(total, side_faces + tip_face, 1e-12 * total);

  // The corner farthest along (1, 1, 1): the plane with that normal's opposite meets it first.
  unsigned corner = 0;
  for (unsigned v = 0; v < area.size(); ++v)
    {
      const auto &X = model.output_coordinates[v], &C = model.output_coordinates[corner];
      if (X[0] + X[1] + X[2] > C[0] + C[1] + C[2])
        corner = v;
    }
  double mean = 0;
  for (unsigned v = 0; v < area.size(); ++v)
    mean += area[v] / area.size();
  ASSERT_GT(std::abs(area[corner] / mean - 1), 0.2); // a corner's area is not the mean's
  // A penalty whose corner stiffness equals the corner's own compliance n . H[0] n, so that
  // the wall's give and the body's share the step: the force depends on the stiffness.
  const double       r3 = 1 / std::sqrt(3.0);
  const unsigned     in = static_cast<unsigned>(model.output_input_index[corner]);
  double             w  = 0;
  for (int e = 0; e < 3; ++e)
    for (int d = 0; d < 3; ++d)
      w += r3 * r3 * model.h(3 * in + e, 0, 3 * corner + d);
  const double penalty = 1 / (w * area[corner]);
  PointInteraction by_penalty(model), by_own(model), by_mean(model);
  double           largest = 0, off_mean = 0;
  int              touching = 0; // steps with the corner in contact
  for (unsigned n = 1; n <= 10; ++n)
    {
      // The plane moves 0.05 mm per step into the corner along -(1, 1, 1).
      const auto  &C     = model.output_coordinates[corner];
      const double depth = 5e-5 * n;
      PlaneTarget  plane;
      plane.normal = {-r3, -r3, -r3};
      plane.point  = {C[0] - r3 * depth, C[1] - r3 * depth, C[2] - r3 * depth};
      PlaneTarget own = plane, at_mean = plane;
      plane.penalty     = penalty;
      own.stiffness     = penalty * area[corner];
      at_mean.stiffness = penalty * mean;
      ASSERT_TRUE(by_penalty.step(&plane, 1) && by_own.step(&own, 1) && by_mean.step(&at_mean, 1));
      const auto &fp = by_penalty.vertex_contact().plane(0), &fo = by_own.vertex_contact().plane(0),
                 &fm = by_mean.vertex_contact().plane(0);
      // The corner alone, while it touches (the pushed beam swings off and back).
      EXPECT_LE(fp.active, 1);
      EXPECT_EQ(fo.active, fp.active);
      touching += fp.active;
      for (int d = 0; d < 3; ++d)
        EXPECT_EQ(fp.force[d], fo.force[d]) << "step " << n;
      EXPECT_EQ(fp.penetration, fo.penetration);
      const double f = std::sqrt(fp.force[0] * fp.force[0] + fp.force[1] * fp.force[1] +
                                 fp.force[2] * fp.force[2]);
      largest  = std::max(largest, f);
      off_mean = std::max(off_mean, std::abs(fm.force[0] - fp.force[0]));
    }
  std::printf("corner area %.4g of the mean; in contact at %d of 10 steps, force up to %.4g N, "
              "the mean's stiffness off by %.3g of it\n", area[corner] / mean, touching, largest,
              off_mean / largest);
  EXPECT_GE(touching, 3);
  EXPECT_GT(largest, 0);
  EXPECT_GT(off_mean, 0.05 * largest);
}

// Device-held plates (virtual coupling, issue 15): each plane is pulled toward its prescribed
// motion by a spring and damper along its normal, solved implicitly with the contact (W + 1/c
// on every pair of its rows), so it stands back where the body pushes hard.
TEST(Runtime, UntruncatedVertexContactWithCoupledPlatesReproducesTheFem)
{
  EXPECT_GE(expect_vertex_contact_reproduces_the_fem(
              R"(, "coupling": {"stiffness_N_m": 30, "damping_N_s_m": 0.2})", "vertex_coupled"),
            4);
}

TEST(Runtime, LoaderRejectsBadFiles)
{
  EXPECT_THROW(load_model(tmp("does-not-exist.h5")), InputError);
  {
    h5::Writer w(tmp("not-a-model.h5"));
    w.attribute("/", "format", std::string("something-else"));
    w.commit();
  }
  EXPECT_THROW(load_model(tmp("not-a-model.h5")), InputError);
  const fem::Scene scene = fem::parse_scene(beam_scene(""), ".");
  make_model(scene, "good.h5");
  EXPECT_NO_THROW(load_model(tmp("good.h5"), 0.002));
  try
    {
      load_model(tmp("good.h5"), 0.001);
      FAIL() << "a different time step must be rejected";
    }
  catch (const InputError &e)
    {
      EXPECT_NE(std::string(e.what()).find("time step"), std::string::npos);
    }
  // A model whose H holds a NaN, and one without H.
  const ImpulseResponseModel m = load_model(tmp("good.h5"));
  for (const bool nan : {true, false})
    {
      h5::Writer w(tmp("bad.h5"));
      w.attribute("/", "format", std::string("irdm-impulse-response"));
      w.attribute("/", "format_version", 1LL);
      w.attribute("/", "time_step_s", 0.002);
      w.attribute("/", "length", static_cast<long long>(2));
      w.attribute("/", "integrator", std::string("newmark"));
      w.attribute("/", "mesh_hash", std::string("0"));
      w.attribute("/", "storage", std::string("double"));
      w.create_group("/outputs");
      w.create_group("/inputs");
      w.create_group("/surface");
      const long long tags[1] = {1}, idx[1] = {0}, tri[3] = {0, 0, 0}, ts[1] = {0};
      const double    xyz[3]  = {0, 0, 0};
      w.write("/outputs/node_tags", {1}, tags);
      w.write("/outputs/coordinates", {1, 3}, xyz);
      w.write("/inputs/node_tags", {1}, tags);
      w.write("/inputs/output_index", {1}, idx);
      w.write("/surface/triangles", {1, 3}, tri);
      w.write("/surface/triangle_surface", {1}, ts);
      w.attribute("/surface", "surface_names", std::string("skin"));
      if (nan)
        {
          std::vector<double> h(3 * 2 * 3, 1.0);
          h[5] = std::nan("");
          w.create_group("/impulse_response");
          w.write("/impulse_response/H", {3, 2, 3}, h.data());
        }
      w.commit();
      try
        {
          load_model(tmp("bad.h5"));
          FAIL() << "a bad model was accepted";
        }
      catch (const InputError &e)
        {
          EXPECT_NE(std::string(e.what()).find(nan ? "NaN" : "missing dataset"), std::string::npos)
            << e.what();
        }
    }
  EXPECT_GT(m.n_inputs, 0u);
}

TEST(Precompute, TwoMpiRanksGiveTheSerialResult)
{
  if (std::system("command -v mpirun > /dev/null 2>&1") != 0)
    GTEST_SKIP() << "mpirun not installed";
  // The beam's model (inputs near the tip), and one with every free surface vertex in and
  // out (H filled by reciprocity on the writing rank).
  const std::string inputs_near_tip =
    R"("inputs": {"within": {"center_m": [0.22, 0.0, 0.01], "radius_m": 0.03}})";
  for (const bool symmetric : {false, true})
    {
      std::string scene = beam_scene("");
      if (symmetric)
        {
          const size_t at = scene.find(inputs_near_tip);
          ASSERT_NE(at, std::string::npos);
          scene.replace(at, inputs_near_tip.size(), R"("inputs": {"surfaces": ["sides", "tip"]})");
        }
      const std::string scene_file = tmp("mpi_scene.json");
      {
        std::ofstream f(scene_file);
        f << scene;
      }
      const std::string serial = tmp("serial.h5"), parallel = tmp("parallel.h5");
      // A clean environment: this test process is itself an MPI singleton, and its OMPI_*
      // variables would confuse a nested mpirun.
      const std::string clean = clean_environment();
      const std::string base  = std::string(IRDM_CLI) + " precompute " + scene_file +
                               " --quiet --restart --chunk 5 --length 20 --out ";
      ASSERT_EQ(std::system((clean + base + serial + " > /dev/null").c_str()), 0);
      ASSERT_EQ(std::system((clean + "mpirun --allow-run-as-root --oversubscribe -np 2 " + base +
                             parallel + " > /dev/null").c_str()),
                0);
      const auto a = load_model(serial), b = load_model(parallel);
      EXPECT_EQ(a.n_inputs == a.n_outputs, symmetric);
      ASSERT_EQ(a.h_double.size(), b.h_double.size());
      size_t differ = 0;
      for (size_t i = 0; i < a.h_double.size(); ++i)
        differ += a.h_double[i] != b.h_double[i];
      EXPECT_EQ(differ, 0u) << "entries of H that differ between 1 and 2 ranks";
      h5::Reader r(parallel);
      EXPECT_EQ(r.double_attribute("/", "precompute_ranks"), 2);
    }
}

TEST(Precompute, ResumesAnInterruptedRunWithoutRedoingChunks)
{
  const fem::Scene scene = fem::parse_scene(beam_scene(""), ".");
  fem::PrecomputeOptions o;
  o.output           = tmp("resume.h5");
  o.inputs_per_chunk = 10;
  o.restart          = true;
  const auto clean   = fem::precompute_impulse_responses(scene, o);
  const auto reference = load_model(o.output);
  fs::remove(o.output);

  // Interrupt after the third chunk is on disk (the progress callback throws).
  int chunks = 0;
  o.log      = [&](const std::string &line) {
    if (line.rfind("chunk", 0) == 0 && ++chunks == 3)
      throw std::runtime_error("interrupted");
  };
  EXPECT_THROW(fem::precompute_impulse_responses(scene, o), std::runtime_error);
  EXPECT_FALSE(fs::exists(o.output)) << "no file under the final name before it is complete";
  EXPECT_TRUE(fs::exists(o.output + ".part"));

  o.log     = {};
  o.restart = false;
  const auto resumed = fem::precompute_impulse_responses(scene, o);
  EXPECT_EQ(resumed.chunks_resumed, 3u);
  EXPECT_EQ(resumed.n_chunks, clean.n_chunks);
  EXPECT_FALSE(fs::exists(o.output + ".part"));
  const auto m = load_model(o.output);
  ASSERT_EQ(m.h_double.size(), reference.h_double.size());
  EXPECT_TRUE(m.h_double == reference.h_double) << "the resumed file differs from a clean run";
}

// The public API's applied force on a grounded body (irdm/irdm.h): a known force held on an
// input vertex is convolved with H, u[n] = sum_s H[s] f[n - s], at every output; the modal
// body reproduces that sum from the file's H (surface shapes in float: 1e-5 of the largest).
TEST(RuntimeApi, AppliedForceOnAGroundedBodyIsTheConvolutionWithH)
{
  const fem::Scene           scene = fem::parse_scene(beam_scene(R"(, "outputs": {"surface": true})"), ".");
  const ImpulseResponseModel model = make_model(scene, "api_force.h5");
  irdm::Body body(irdm::Model::load(tmp("api_force.h5"), {0}));
  const unsigned vertex = model.input_output_index[0];
  ASSERT_TRUE(body.model().can_push(vertex));
  const std::array<double, 3> F = {0.01, -0.02, -0.05}; // N
  const auto force = [&](const unsigned n) { return n < 30 ? 1 + 0.5 * std::sin(0.3 * n) : 0.0; };
  irdm::AppliedForce applied{vertex, {}};
  irdm::StepInput    in;
  in.forces   = &applied;
  in.n_forces = 1;
  irdm::StepOutput    out;
  std::vector<double> u(model.n_outputs);
  double              err = 0, largest = 0;
  for (unsigned n = 0; n < model.length; ++n)
    {
      for (int d = 0; d < 3; ++d)
        applied.force[d] = F[d] * force(n);
      g_count_allocations = true;
      const bool stepped  = body.step(in, out);
      g_count_allocations = false;
      ASSERT_TRUE(stepped) << body.refusal();
      body.surface_displacement(u.data());
      for (unsigned j = 0; j < model.n_outputs; ++j)
        {
          double expected = 0;
          for (unsigned s = 0; s <= n; ++s)
            for (int d = 0; d < 3; ++d)
              expected += model.h(d, s, j) * F[d] * force(n - s);
          largest = std::max(largest, std::abs(expected));
          err     = std::max(err, std::abs(u[j] - expected));
        }
    }
  EXPECT_EQ(g_allocations, 0);
  EXPECT_GT(largest, 1e-4);
  EXPECT_LT(err / largest, 1e-5);
  EXPECT_EQ(out.steps, model.length);
  EXPECT_NEAR(out.time, model.length * model.time_step, 1e-15);
}

// What a body does not take is refused with a reason, no step is taken, and the next good
// step goes on; options that do not fit the model, and files that are no model, throw.
TEST(RuntimeApi, RefusesWhatABodyDoesNotTakeAndSaysWhy)
{
  const fem::Scene scene = fem::parse_scene(beam_scene(""), ".");
  make_model(scene, "api_refusals.h5");
  const irdm::Model model = irdm::Model::load(tmp("api_refusals.h5"));
  EXPECT_EQ(model.kind(), "modal");
  EXPECT_FALSE(model.free_body());
  EXPECT_NEAR(model.time_step(), scene.time_step, 1e-15);
  EXPECT_FALSE(model.can_push(static_cast<unsigned>(model.rest_positions().size())));
  irdm::Body body(model);
  irdm::Probe probe;
  probe.n_patch           = 1;
  probe.patch_vertices[0] = 0;
  probe.patch_weights[0]  = 1;
  for (unsigned v = 0; v < model.rest_positions().size(); ++v)
    if (model.can_push(v))
      probe.patch_vertices[0] = v;
  irdm::Plane      floor;
  irdm::StepInput  in;
  irdm::StepOutput out;
  in.probes   = &probe;
  in.n_probes = 1;
  in.planes   = &floor;
  in.n_planes = 1;
  EXPECT_FALSE(body.step(in, out));
  EXPECT_NE(std::string(body.refusal()).find("not both"), std::string::npos) << body.refusal();
  in.n_planes = 0;
  in.n_probes = irdm::StepInput::max_probes + 1;
  EXPECT_FALSE(body.step(in, out));
  EXPECT_NE(std::string(body.refusal()).find("out of range"), std::string::npos);
  in.n_probes = 1;
  probe.patch_vertices[0] = static_cast<unsigned>(model.rest_positions().size()); // no such vertex
  EXPECT_FALSE(body.step(in, out));
  EXPECT_EQ(out.steps, 0);
  for (unsigned v = 0; v < model.rest_positions().size(); ++v)
    if (model.can_push(v))
      probe.patch_vertices[0] = v;
  probe.displacement = {0, 0, -1e-3};
  ASSERT_TRUE(body.step(in, out)) << body.refusal();
  EXPECT_STREQ(body.refusal(), "");
  EXPECT_EQ(out.steps, 1);
  EXPECT_LT(out.probe_force[0][2], 0); // the force on the body: down, as the device pushes
  EXPECT_NEAR(out.probe_displacement[0][2], -1e-3, 1e-12);

  EXPECT_THROW(body.set_motion({0, 0, 0}, {1, 0, 0, 0}, {0, 0, 0}, {0, 0, 0}), irdm::InputError);
  irdm::BodyOptions spin;
  spin.centrifugal = true;
  EXPECT_THROW(irdm::Body(model, spin), irdm::InputError);
  irdm::ModelOptions direct;
  direct.direct = true;
  const irdm::Model direct_model = irdm::Model::load(tmp("api_refusals.h5"), direct);
  EXPECT_EQ(direct_model.kind(), "direct");
  EXPECT_THROW(direct_model.make_surface_state(), irdm::InputError);
  {
    irdm::Body direct_body(direct_model);
    irdm::AppliedForce applied{probe.patch_vertices[0], {0, 0, 1}};
    irdm::StepInput    forces;
    forces.forces   = &applied;
    forces.n_forces = 1;
    EXPECT_FALSE(direct_body.step(forces, out));
    EXPECT_NE(std::string(direct_body.refusal()).find("applied forces"), std::string::npos);
  }
  // Not a model: an HDF5 file of another kind, and a text file.
  {
    h5::Writer w(tmp("api_not_a_model.h5"));
    w.attribute("/", "format", std::string("something-else"));
  }
  EXPECT_THROW(irdm::Model::load(tmp("api_not_a_model.h5")), irdm::InputError);
  std::ofstream(tmp("api_text.h5")) << "not hdf5\n";
  EXPECT_THROW(irdm::Model::load(tmp("api_text.h5")), irdm::InputError);
  EXPECT_THROW(irdm::Model::load(tmp("api_missing.h5")), irdm::InputError);
}

namespace
{
  // A small reduced model of the soft beam, every element, damped as beam_scene or undamped:
  // clamped, 6 modes and 3 directions of the derivatives of 3 (r = 10); free (nothing fixed,
  // a floating frame's model), its six rigid modes, 6 modes, the six uniform strain fields and
  // 3 directions of the derivatives of 2 (r = 21).
  irdm::ReducedNonlinearModel
  make_reduced_beam(const bool damped, const bool free_body = false)
  {
    std::string scene = irdm_test::beam_scene(R"(, "kinematics": "nonlinear")");
    if (!damped)
      scene.replace(scene.find("[0.05, 0.05]"), 12, "[0, 0]");
    fem::Scene s = fem::parse_scene(scene, ".");
    if (free_body)
      s.fixed_surfaces.clear();
    fem::ReducedModelOptions o;
    o.output = tmp(std::string(free_body ? "reduced_free_beam_r21" : "reduced_beam_r10") + (damped ? ".h5" : "_undamped.h5"));
    o.modes            = 6;
    o.derivative_modes = free_body ? 2 : 3;
    o.residual_modes   = false;
    o.basis_size       = free_body ? 21 : 10;
    std::filesystem::remove(o.output);
    fem::precompute_reduced_model(s, o);
    return irdm::load_reduced_nonlinear_model(o.output, s.time_step);
  }

  const irdm::ReducedNonlinearModel &
  reduced_beam(const bool damped = true)
  {
    static const irdm::ReducedNonlinearModel with = make_reduced_beam(true), without = make_reduced_beam(false);
    return damped ? with : without;
  }

  // The surface vertex at the middle of the beam's free end's top edge, and a coupling to it
  // whose device goes 4 mm down over the first 0.06 s (a half cosine: no jump in velocity),
  // then holds.
  irdm::ReducedProbe
  tip_coupling(const irdm::ReducedNonlinearModel &m, const int step, const double damping)
  {
    irdm::ReducedProbe p;
    p.n_patch = 1;
    double best = 1e300;
    for (unsigned v = 0; v < m.coordinates.size(); ++v)
      {
        const auto  &x = m.coordinates[v];
        const double d = std::hypot(x[0] - 0.25, x[1], x[2] - 0.01);
        if (d < best)
          best = d, p.vertices[0] = v;
      }
    p.weights[0]        = 1;
    const double t      = m.time_step * (step + 1), ramp = 0.06;
    const double phase  = M_PI * std::min(t / ramp, 1.0);
    p.target            = {0, 0, -0.002 * (1 - std::cos(phase))};
    p.target_velocity   = {0, 0, -0.002 * std::sin(phase) * M_PI / ramp};
    p.stiffness         = 200;
    p.damping           = damping;
    return p;
  }
} // namespace

// The reduced nonlinear model's step (Newton, cubature, planes, vertex forces, a coupled probe,
// and a step cut into parts), its surface and a force loop's local compliance allocate nothing,
// with the tangent made in the step or over steps.
TEST(ReducedRuntime, StepAndSurfaceAllocateNothing)
{
  const irdm::ReducedNonlinearModel &m = reduced_beam();
  for (const unsigned tangent_steps : {0u, 3u})
    {
      irdm::ReducedBodyOptions   o;
      o.tangent_steps         = tangent_steps;
      // Staged: asking at every step that iterates, and going on with the kept tangent where
      // it hardly steers (the jump is then solved in parts, as it is with it made at once).
      o.tangent_refresh_ratio = tangent_steps > 0 ? 0 : o.tangent_refresh_ratio;
      o.tangent_at_once_ratio = tangent_steps > 0 ? 1e300 : o.tangent_at_once_ratio;
      irdm::ReducedNonlinearBody body(m, o);
      g_allocations       = 0;
      g_count_allocations = true;
      body.prepare_tangent();
      g_count_allocations = false;
      EXPECT_EQ(g_allocations, 0) << "prepare_tangent";
      std::vector<double>        u(3 * m.surface_vertex.size());
      irdm::ReducedPlane         plane;
      plane.normal = {0, 0, -1};
      const irdm::ReducedVertexForce push{static_cast<unsigned>(m.surface_vertex.size() - 1), {0, 0, -1e-3}};
      int    most = 0;
      double uc[3], vc[3], ac[3], W[9];
      for (int k = 0; k < 40; ++k)
        {
          // The plane jumps 5 mm into the beam's top at step 20 (the step that needs parts) and
          // goes on down 0.5 mm a step.
          plane.point                    = {0, 0, 0.01 - (k < 20 ? -1e-3 : 5e-3 + 5e-4 * (k - 20))};
          const irdm::ReducedProbe probe = tip_coupling(m, k, 0.5);
          g_allocations                  = 0;
          g_count_allocations            = true;
          body.step(&plane, 1, &push, 1, &probe, k < 20 ? 1 : 0);
          body.surface_displacement(u.data());
          body.point_state(probe.vertices.data(), probe.weights.data(), 1, uc, vc, ac, W);
          g_count_allocations = false;
          EXPECT_EQ(g_allocations, 0) << "step " << k;
          most = std::max(most, body.plane_vertices(0));
        }
      EXPECT_GT(most, 0) << "the plane reached the beam";
      EXPECT_GT(body.cut_steps(), 0u) << "the jump was solved in parts";
      if (tangent_steps > 0)
        {
          EXPECT_GT(body.staged_tangent_evaluations(), 0u) << "tangents made over steps";
        }
    }
}

// A planes' tangent kept while the contacts stay, and a factorization kept while the tangent
// stays, are the same matrices as those made every time: the steps are bit for bit those of a
// body that keeps neither, while the plane's contacts change as it goes into the beam and out,
// across a jump solved in parts (a shorter step), and with a coupled probe whose coupling (kept
// while its patch's rows and weight stay) crosses that jump (its damper's weight follows the
// step's length), moves to another vertex, and becomes one-sided and lets go. A kept matrix that
// missed a change would take other Newton directions and end its steps elsewhere within the
// stop.
TEST(ReducedRuntime, AKeptFactorizationTakesTheSameSteps)
{
  const irdm::ReducedNonlinearModel &m = reduced_beam();
  irdm::ReducedBodyOptions           every;
  every.keep_factorization = false;
  irdm::ReducedNonlinearBody kept(m), each(m, every);
  std::set<int>              contacts;
  // The second vertex the probe moves to: the one nearest (0.2, 0, 0.01).
  unsigned second = 0;
  for (unsigned v = 0; v < m.coordinates.size(); ++v)
    if (std::hypot(m.coordinates[v][0] - 0.2, m.coordinates[v][1], m.coordinates[v][2] - 0.01) <
        std::hypot(m.coordinates[second][0] - 0.2, m.coordinates[second][1], m.coordinates[second][2] - 0.01))
      second = v;
  int let_go = 0;         // steps with the one-sided probe given and pulling (inactive)
  int cut_with_probe = 0; // steps solved in parts with the probe coupled
  for (int k = 0; k < 50; ++k)
    {
      irdm::ReducedPlane plane;
      // In by 3 mm and out over steps 0 to 40, 10 mm deeper at once over steps 20 to 23, then
      // 1 mm in.
      const double depth = 3e-3 * std::sin(M_PI * k / 40.0) + (k >= 20 && k < 24 ? 0.01 : 0);
      plane.normal       = {0, 0, -1};
      plane.point        = {0, 0, 0.01 - std::max(depth, 1e-3)};
      // The probe over steps 21 to 35: at the tip, at the second vertex from step 27, one-sided
      // from step 31 and its target lifted 1 mm above the rest surface from step 33.
      irdm::ReducedProbe probe = tip_coupling(m, k, 0.5);
      if (k >= 27)
        probe.vertices[0] = second;
      if (k >= 31)
        probe.unilateral = true;
      if (k >= 33)
        probe.target = {0, 0, 1e-3}, probe.target_velocity = {0, 0, 0};
      const int  n_probes   = k >= 21 && k < 36 ? 1 : 0;
      const auto cut_before = kept.cut_steps();
      kept.step(&plane, 1, nullptr, 0, &probe, n_probes);
      each.step(&plane, 1, nullptr, 0, &probe, n_probes);
      cut_with_probe += n_probes > 0 && kept.cut_steps() > cut_before;
      contacts.insert(kept.plane_vertices(0));
      if (k >= 33 && n_probes > 0 && kept.probe_force(0) == std::array<double, 3>{0, 0, 0})
        ++let_go;
      ASSERT_EQ(kept.plane_vertices(0), each.plane_vertices(0)) << "step " << k;
      for (Eigen::Index i = 0; i < kept.coordinates().size(); ++i)
        ASSERT_EQ(kept.coordinates()(i), each.coordinates()(i)) << "step " << k << ", coordinate " << i;
    }
  EXPECT_GE(contacts.size(), 4u) << "the contacts changed as the plane went";
  EXPECT_GT(kept.cut_steps(), 0u) << "the jump was solved in parts";
  EXPECT_GE(let_go, 1) << "the one-sided probe let go";
  EXPECT_GE(cut_with_probe, 1) << "a step with the probe was solved in parts (the coupling's weight then changes)";
  EXPECT_LT(kept.factorizations(), each.factorizations()) << "kept: fewer";
  EXPECT_EQ(kept.tangent_evaluations(), each.tangent_evaluations());
  std::cout << "factorizations: kept " << kept.factorizations() << ", made every iteration " << each.factorizations()
            << "; steps solved in parts " << kept.cut_steps() << "\n";
}

// The planes' tangent kept is made again where a plane turns while its contacts stay: the beam
// squeezed 1 mm between a floor and a plane on its top, then the top plane turning a little
// each step about an axis across the beam, its contacts often the same from one step to the
// next; the steps stay bit for bit those of a body that keeps nothing (a kept tangent of the
// earlier normal would take other Newton directions).
TEST(ReducedRuntime, AKeptPlanesTangentFollowsATurningPlane)
{
  const irdm::ReducedNonlinearModel &m = reduced_beam();
  irdm::ReducedBodyOptions           every;
  every.keep_factorization = false;
  irdm::ReducedNonlinearBody kept(m), each(m, every);
  double                     bottom = 1e300, top = -1e300;
  for (const auto &x : m.coordinates)
    bottom = std::min(bottom, x[2]), top = std::max(top, x[2]);
  int steady = 0, previous = -1; // turning steps with as many contacts as the step before
  for (int k = 0; k < 200; ++k)
    {
      const double                      turn = k < 150 ? 0 : 2e-4 * (k - 149); // rad, about the y axis
      std::array<irdm::ReducedPlane, 2> planes;
      planes[0].normal = {std::sin(turn), 0, -std::cos(turn)};
      planes[0].point  = {0.125, 0, top - 1e-3};
      planes[1].normal = {0, 0, 1};
      planes[1].point  = {0, 0, bottom + 1e-3};
      kept.step(planes.data(), 2);
      each.step(planes.data(), 2);
      if (k >= 150 && kept.plane_vertices(0) == previous && previous > 0)
        ++steady;
      previous = kept.plane_vertices(0);
      ASSERT_EQ(kept.plane_vertices(0), each.plane_vertices(0)) << "step " << k;
      for (Eigen::Index i = 0; i < kept.coordinates().size(); ++i)
        ASSERT_EQ(kept.coordinates()(i), each.coordinates()(i)) << "step " << k << ", coordinate " << i;
    }
  EXPECT_GE(steady, 10) << "the turning plane's contacts stayed over some steps";
}

// A tangent made over steps (tangent_steps) is the tangent made at once at the state where the
// step that asked for it ended: each time one is taken into use, N steps after that step, it
// equals prepare_tangent()'s (a step's own evaluation, at its iterate x = q) at that state, on
// a body given the same inputs up to there (the same steps, bit for bit), to the rounding of
// the order of summation (float rows; double with U's rows in double), with one element piece
// and one range of rows, with several of each. The beam, its tip pressed 4 mm and let go, asks
// at every iterating step (tangent_refresh_ratio 0). The tangent it replaces differs by more
// than 1e-4 of the largest entry, far more than that rounding: the check can fail.
TEST(ReducedRuntime, ATangentMadeOverStepsIsTheTangentMadeAtOnce)
{
  const irdm::ReducedNonlinearModel &m = reduced_beam();
  const auto inputs = [&](irdm::ReducedNonlinearBody &body, const int k) {
    const irdm::ReducedProbe probe = tip_coupling(m, k, 0.5);
    body.step(nullptr, 0, nullptr, 0, &probe, k < 45 ? 1 : 0);
  };
  for (const bool in_float : {true, false})
    for (const unsigned pieces : {1u, 2u, 5u, 9u})
      {
        irdm::ReducedBodyOptions o;
        o.tangent_steps         = pieces;
        o.tangent_refresh_ratio = 0;
        o.single_precision_rows = in_float;
        irdm::ReducedNonlinearBody staged(m, o);
        int                        checked = 0;
        double                     worst = 0, moved = 0;
        for (int k = 0; k < 70; ++k)
          {
            const Eigen::MatrixXd before = staged.body_tangent();
            const auto            taken  = staged.staged_tangent_evaluations();
            inputs(staged, k);
            if (staged.staged_tangent_evaluations() == taken)
              continue;
            // Made at the end of step k - pieces: the same inputs up to there, then at once.
            irdm::ReducedNonlinearBody reference(m, o);
            for (int j = 0; j <= k - int(pieces); ++j)
              inputs(reference, j);
            reference.prepare_tangent();
            const Eigen::MatrixXd T = reference.body_tangent().triangularView<Eigen::Lower>();
            const Eigen::MatrixXd S = staged.body_tangent().triangularView<Eigen::Lower>();
            const Eigen::MatrixXd B = before.triangularView<Eigen::Lower>();
            const double          scale = T.cwiseAbs().maxCoeff();
            worst = std::max(worst, (S - T).cwiseAbs().maxCoeff() / scale);
            moved = std::max(moved, (B - T).cwiseAbs().maxCoeff() / scale);
            ++checked;
          }
        const std::string what = std::to_string(pieces) + (in_float ? " pieces, float" : " pieces, double");
        EXPECT_GE(checked, 4) << what << ": tangents made over steps and taken";
        EXPECT_LT(worst, in_float ? 1e-6 : 1e-12) << what;
        EXPECT_GT(moved, 1e-4) << what << ": the tangent in use before differs (the check can fail)";
        std::cout << what << ": " << checked << " tangents, largest difference " << worst
                  << " of the largest entry, the one before it differs by up to " << moved << "\n";
      }
}

// A tangent made at once cancels the one in the making, which shares its work space: otherwise
// that one's pieces would be summed on blocks the evaluation at once overwrote, and taken into
// use on its schedule. Two bodies given the same inputs, asking at every step, their tangent
// over 12 steps: the one given prepare_tangent() at step 6 takes no tangent made over steps
// before step 18, where the other takes the one asked for at step 0, at step 12.
TEST(ReducedRuntime, ATangentMadeAtOnceCancelsTheOneInTheMaking)
{
  const irdm::ReducedNonlinearModel &m = reduced_beam();
  irdm::ReducedBodyOptions           o;
  o.tangent_steps         = 12;
  o.tangent_refresh_ratio = 0;
  o.tangent_at_once_ratio = 1e300; // no step makes one at once for its contraction
  irdm::ReducedNonlinearBody interrupted(m, o), calm(m, o);
  unsigned long              taken_early = 0, calm_taken_at = 0;
  for (int k = 0; k < 40; ++k)
    {
      const irdm::ReducedProbe probe = tip_coupling(m, k, 0.5);
      if (k == 6)
        interrupted.prepare_tangent();
      const auto taken = calm.staged_tangent_evaluations();
      interrupted.step(nullptr, 0, nullptr, 0, &probe, 1);
      calm.step(nullptr, 0, nullptr, 0, &probe, 1);
      if (calm_taken_at == 0 && calm.staged_tangent_evaluations() > taken)
        calm_taken_at = k;
      if (k < 18)
        taken_early = interrupted.staged_tangent_evaluations();
    }
  EXPECT_EQ(calm.tangent_evaluations(), 1u) << "the first step's alone at once";
  EXPECT_EQ(calm_taken_at, 12u) << "asked at step 0, made at steps 1 to 12";
  EXPECT_EQ(interrupted.tangent_evaluations(), 2u);
  EXPECT_EQ(taken_early, 0u) << "the one in the making at step 6 was cancelled";
  EXPECT_GE(interrupted.staged_tangent_evaluations(), 1u) << "and later ones are made";
}

// Newton's root is the residual's, whichever tangent steers it: a body whose tangent is made
// over 4 steps ends every step where one making it at once does, within the stop; it makes
// fewer at once, and none after prepare_tangent(), which changes no step (the rest tangent is
// the one the first step makes).
TEST(ReducedRuntime, ATangentMadeOverStepsLeavesTheSteps)
{
  const irdm::ReducedNonlinearModel &m = reduced_beam();
  irdm::ReducedBodyOptions           o;
  o.tangent_steps = 4;
  irdm::ReducedNonlinearBody at_once(m), prepared(m), staged(m, o);
  prepared.prepare_tangent();
  staged.prepare_tangent();
  EXPECT_EQ(prepared.tangent_evaluations(), 1u);
  const Eigen::MatrixXd rest_tangent = prepared.body_tangent();
  EXPECT_GT(rest_tangent.norm(), 0) << "made";
  double worst = 0;
  for (int k = 0; k < 120; ++k)
    {
      // Pressed 4 mm, held, let go at step 45; then a plane pushes 3 mm into the top and out.
      const irdm::ReducedProbe probe = tip_coupling(m, k, 0.5);
      irdm::ReducedPlane       plane;
      plane.normal   = {0, 0, -1};
      plane.point    = {0, 0, 0.01 - (k < 70 ? -1e-3 : 3e-3 * std::sin(M_PI * (k - 70) / 50.0))};
      const int n_probes = k < 45 ? 1 : 0;
      for (auto *b : {&at_once, &prepared, &staged})
        b->step(&plane, 1, nullptr, 0, &probe, n_probes);
      if (k == 0)
        {
          EXPECT_EQ(prepared.tangent_evaluations(), 1u) << "the first step made none";
          EXPECT_EQ(at_once.tangent_evaluations(), 1u) << "the first step made one";
          const Eigen::MatrixXd first = at_once.body_tangent().triangularView<Eigen::Lower>();
          EXPECT_EQ(first, Eigen::MatrixXd(rest_tangent.triangularView<Eigen::Lower>())) << "the same";
        }
      for (Eigen::Index i = 0; i < at_once.coordinates().size(); ++i)
        ASSERT_EQ(prepared.coordinates()(i), at_once.coordinates()(i)) << "step " << k;
      const double off = (staged.coordinates() - at_once.coordinates()).norm();
      worst            = std::max(worst, off / at_once.coordinates().norm());
    }
  EXPECT_LT(worst, 1e-6);
  EXPECT_GT(staged.staged_tangent_evaluations(), 0u);
  EXPECT_LT(staged.tangent_evaluations(), at_once.tangent_evaluations());
  EXPECT_EQ(at_once.failed_steps() + staged.failed_steps(), 0u);
  std::cout << "tangents at once: " << at_once.tangent_evaluations() << "; over steps "
            << staged.staged_tangent_evaluations() << " and at once " << staged.tangent_evaluations()
            << "; largest relative difference of q " << worst << "\n";
}

// The allocation count sees both routes to the heap: a new-expression, and Eigen's storage
// (malloc), here and inside the runtime library (a reduced body's constructor sizes its Eigen
// matrices there). Without the malloc wrap, the second route would pass unseen.
TEST(ReducedRuntime, TheAllocationCountSeesEigensMallocs)
{
  const Eigen::VectorXd a = Eigen::VectorXd::LinSpaced(64, 0, 63);
  g_allocations           = 0;
  g_count_allocations     = true;
  const auto p            = std::make_unique<double>(2);
  g_count_allocations     = false;
  EXPECT_GE(g_allocations, 1) << "a new-expression";
  g_allocations           = 0;
  g_count_allocations     = true;
  const Eigen::VectorXd b = *p * a;
  g_count_allocations     = false;
  EXPECT_GE(g_allocations, 1) << "an Eigen vector's storage (malloc)";
  EXPECT_EQ(b.sum(), 2 * a.sum());
  const irdm::ReducedNonlinearModel &m = reduced_beam();
  g_allocations = g_new_allocations = 0;
  g_count_allocations               = true;
  {
    const irdm::ReducedNonlinearBody body(m);
  }
  g_count_allocations = false;
  EXPECT_GE(g_allocations - g_new_allocations, 1) << "the library's Eigen storage (malloc, not operator new)";
}

// A free body's step in its floating frame (the frame carried at each step's end, the planes,
// gravity and the vertex forces turned into it; the projected forces' torques made the true ones
// or not)
// and its world outputs allocate nothing either:
// the beam thrown spinning onto a floor under gravity, a force at one vertex.
TEST(ReducedRuntime, AFloatingStepAllocatesNothing)
{
  static const irdm::ReducedNonlinearModel m = make_reduced_beam(true, true);
  ASSERT_EQ(m.rigid_modes, 6u);
  ASSERT_EQ(m.uniform_strain_fields, 6u);
  for (const bool true_torques : {false, true})
    {
      irdm::ReducedBodyOptions options;
      options.keep_angular_momentum = true_torques;
      irdm::ReducedNonlinearBody body(m, options);
      ASSERT_TRUE(body.floating());
      ASSERT_TRUE(body.start({0, 0, -9.81}, {0.1, 0, -0.8}, {0, 3, 1}));
      std::vector<double> u(3 * m.surface_vertex.size());
      irdm::ReducedPlane  floor;
      floor.normal = {0, 0, 1};
      floor.point  = {0, 0, -0.012};
      const irdm::ReducedVertexForce push{0, {0, 1e-3, 0}};
      int most = 0;
      for (int k = 0; k < 40; ++k)
        {
          g_allocations       = 0;
          g_count_allocations = true;
          body.step(&floor, 1, &push, 1);
          body.surface_displacement(u.data());
          const Eigen::Vector3d c = body.center_of_mass();
          g_count_allocations     = false;
          EXPECT_EQ(g_allocations, 0) << "step " << k << (true_torques ? ", true torques" : "");
          EXPECT_TRUE(c.allFinite());
          most = std::max(most, body.plane_vertices(0));
        }
      EXPECT_GT(most, 0) << "the beam reached the floor";
      EXPECT_GT((body.frame_rotation() - Eigen::Matrix3d::Identity()).norm(), 0.01) << "the frame turned";
    }
}

// A floating body's tangent made over steps is the one made at once at the state the next step
// starts from, in the frame the carry moved it into: the free beam thrown spinning onto a floor
// with gravity, its tangent over 3 steps, asking at every iterating step; each one taken into
// use equals prepare_tangent()'s on a body given the same inputs up to step k - 3, to float
// rounding, and the one it replaces differs by far more.
TEST(ReducedRuntime, AFloatingTangentMadeOverStepsIsTheOneMadeAtOnce)
{
  static const irdm::ReducedNonlinearModel m = make_reduced_beam(true, true);
  irdm::ReducedBodyOptions                 o;
  o.tangent_steps         = 3;
  o.tangent_refresh_ratio = 0;
  irdm::ReducedPlane floor;
  floor.normal = {0, 0, 1};
  floor.point  = {0, 0, -0.012};
  const auto thrown = [&] {
    auto body = std::make_unique<irdm::ReducedNonlinearBody>(m, o);
    EXPECT_TRUE(body->start({0, 0, -9.81}, {0.1, 0, -0.8}, {0, 3, 1}));
    return body;
  };
  const auto staged = thrown();
  int        checked = 0, touching = 0;
  double     worst = 0, moved = 0;
  for (int k = 0; k < 120; ++k)
    {
      const Eigen::MatrixXd before = staged->body_tangent();
      const auto            taken  = staged->staged_tangent_evaluations();
      staged->step(&floor, 1);
      touching += staged->plane_vertices(0) > 0;
      if (staged->staged_tangent_evaluations() == taken)
        continue;
      const auto reference = thrown();
      for (int j = 0; j <= k - int(o.tangent_steps); ++j)
        reference->step(&floor, 1);
      reference->prepare_tangent();
      const Eigen::MatrixXd T = reference->body_tangent().triangularView<Eigen::Lower>();
      const Eigen::MatrixXd S = staged->body_tangent().triangularView<Eigen::Lower>();
      const Eigen::MatrixXd B = before.triangularView<Eigen::Lower>();
      const double          scale = T.cwiseAbs().maxCoeff();
      worst = std::max(worst, (S - T).cwiseAbs().maxCoeff() / scale);
      moved = std::max(moved, (B - T).cwiseAbs().maxCoeff() / scale);
      ++checked;
    }
  EXPECT_GT(touching, 0) << "the beam reached the floor";
  EXPECT_GT((staged->frame_rotation() - Eigen::Matrix3d::Identity()).norm(), 0.01) << "the frame turned";
  EXPECT_GE(checked, 4);
  EXPECT_LT(worst, 1e-6);
  EXPECT_GT(moved, 1e-4) << "the tangent in use before differs (the check can fail)";
  std::cout << checked << " tangents, largest difference " << worst << " of the largest entry, the one before it "
            << moved << "\n";
}

// A coupled probe is solved with the body: its force is the spring's k (d - u_p) at the step's
// end, and the body it moves is the body the same forces move when applied as known forces
// (to Newton's tolerance). A coupling that is not positive, or a patch off the surface, is
// refused without a step.
TEST(ReducedRuntime, ACoupledProbePushesAsItsForceAppliedWould)
{
  const irdm::ReducedNonlinearModel &m = reduced_beam();
  irdm::ReducedNonlinearBody         coupled(m), forced(m);
  double                             largest = 0, worst_spring = 0, worst_path = 0;
  for (int k = 0; k < 60; ++k)
    {
      const irdm::ReducedProbe probe = tip_coupling(m, k, 0);
      ASSERT_TRUE(coupled.step(nullptr, 0, nullptr, 0, &probe, 1)) << k;
      const auto                    &f = coupled.probe_force(0);
      const auto                     u = coupled.probe_displacement(0);
      const irdm::ReducedVertexForce as_force{probe.vertices[0], f};
      ASSERT_TRUE(forced.step(nullptr, 0, &as_force, 1));
      for (int d = 0; d < 3; ++d)
        worst_spring = std::max(worst_spring, std::abs(f[d] - probe.stiffness * (probe.target[d] - u[d])));
      largest    = std::max(largest, std::hypot(f[0], f[1], f[2]));
      worst_path = std::max(worst_path, (coupled.coordinates() - forced.coordinates()).norm() /
                                          std::max(coupled.coordinates().norm(), 1e-300));
    }
  EXPECT_GT(largest, 0.01) << "the coupling pressed the beam";
  EXPECT_LT(worst_spring, 1e-12 * largest);
  EXPECT_LT(worst_path, 1e-6);
  irdm::ReducedProbe bad = tip_coupling(m, 0, 0);
  bad.stiffness          = 0;
  EXPECT_FALSE(coupled.step(nullptr, 0, nullptr, 0, &bad, 1));
  bad                    = tip_coupling(m, 0, 0);
  bad.vertices[0]        = static_cast<unsigned>(m.surface_vertex.size());
  EXPECT_FALSE(coupled.step(nullptr, 0, nullptr, 0, &bad, 1));
}

// The local compliance a force loop works on is the step's derivative: from one pressed state,
// two steps with forces differing by delta end with the point W delta apart (to first order;
// Newton's method proper, so that W is the tangent at the step's end). Undamped to round-off;
// damped within the damping force's dependence on the deformation, which the tangent leaves
// out as the FEM's does.
TEST(ReducedRuntime, PointComplianceIsTheStepsDerivative)
{
  for (const bool damped : {false, true})
    {
      const irdm::ReducedNonlinearModel &m = reduced_beam(damped);
      irdm::ReducedBodyOptions   o;
      o.reuse_tangent = false;
      irdm::ReducedNonlinearBody body(m, o);
      const irdm::ReducedProbe   probe = tip_coupling(m, 0, 0);
      irdm::ReducedVertexForce   f{probe.vertices[0], {0, 0, -0.3}};
      for (int k = 0; k < 30; ++k)
        ASSERT_TRUE(body.step(nullptr, 0, &f, 1));
      // The step from here with f, and with f + delta along each axis in turn.
      irdm::ReducedNonlinearBody a = body;
      ASSERT_TRUE(a.step(nullptr, 0, &f, 1));
      double ua[3], v[3], acc[3], W[9];
      ASSERT_TRUE(a.point_state(probe.vertices.data(), probe.weights.data(), 1, ua, v, acc, W));
      EXPECT_LT(ua[2], -1e-3) << "the force bent the beam";
      double worst = 0;
      for (int d = 0; d < 3; ++d)
        {
          irdm::ReducedNonlinearBody b = body;
          irdm::ReducedVertexForce   g = f;
          const double               delta = 1e-4;
          g.force[d] += delta;
          ASSERT_TRUE(b.step(nullptr, 0, &g, 1));
          double ub[3], Wb[9];
          ASSERT_TRUE(b.point_state(probe.vertices.data(), probe.weights.data(), 1, ub, v, acc, Wb));
          double column = 0, miss = 0;
          for (int i = 0; i < 3; ++i)
            column += W[3 * i + d] * W[3 * i + d],
              miss += std::pow((ub[i] - ua[i]) / delta - W[3 * i + d], 2);
          worst = std::max(worst, std::sqrt(miss / column));
        }
      std::printf("%s: compliance against the step's finite difference %.3g\n",
                  damped ? "damped" : "undamped", worst);
      // Undamped, the tangent is the step's; damped, it leaves out the damping force's
      // dependence on the deformation (as the FEM's does).
      EXPECT_LT(worst, damped ? 0.02 : 1e-5);
    }
}

// The public API takes a reduced nonlinear model as it takes the others: Model::load knows the
// kind, and Body::step hands planes, applied forces and coupled probes to the reduced body's
// own step (the same numbers as that step given the same inputs, bit for bit). A rigid probe or
// a coupled plate is refused with a reason.
TEST(ReducedRuntime, ThePublicApiRunsAReducedModel)
{
  const irdm::ReducedNonlinearModel m     = make_reduced_beam(true); // the file in this test's folder
  const irdm::Model                 model = irdm::Model::load(tmp("reduced_beam_r10.h5"));
  ASSERT_EQ(model.kind(), "reduced_nonlinear");
  EXPECT_EQ(model.time_step(), m.time_step);
  EXPECT_EQ(model.rest_positions().size(), m.coordinates.size());
  irdm::Body                 body(model);
  irdm::ReducedNonlinearBody direct(m);
  irdm::StepOutput           out;
  irdm::Plane                plane;
  plane.normal = {0, 0, -1};
  irdm::Probe probe;
  const irdm::ReducedProbe coupled = tip_coupling(m, 0, 0.5);
  probe.n_patch           = 1;
  probe.patch_vertices[0] = coupled.vertices[0];
  probe.patch_weights[0]  = 1;
  probe.coupling_stiffness = coupled.stiffness, probe.coupling_damping = coupled.damping;
  probe.direction          = coupled.direction;
  const irdm::AppliedForce push{static_cast<unsigned>(m.surface_vertex.size() - 1), {0, 0, -1e-3}};
  ASSERT_TRUE(model.can_push(push.vertex));
  std::array<double, 3> device_before{};
  for (int k = 0; k < 40; ++k)
    {
      plane.point             = {0, 0, 0.01 - 1e-4 * k}; // into the top from step 1 on
      const irdm::ReducedProbe target = tip_coupling(m, k, 0.5);
      probe.displacement      = target.target;
      irdm::StepInput in;
      in.planes = &plane, in.n_planes = 1, in.probes = &probe, in.n_probes = 1, in.forces = &push, in.n_forces = 1;
      ASSERT_TRUE(body.step(in, out)) << body.refusal();
      // The same inputs to the reduced body's own step: the device's velocity as the API takes
      // it, from its displacement one step before.
      irdm::ReducedProbe same = target;
      for (int d = 0; d < 3; ++d)
        same.target_velocity[d] = k == 0 ? 0 : (same.target[d] - device_before[d]) / m.time_step;
      device_before                   = same.target;
      const irdm::ReducedPlane     p{plane.normal, plane.point, 0, 0};
      const irdm::ReducedVertexForce f{push.vertex, push.force};
      direct.step(&p, 1, &f, 1, &same, 1);
      EXPECT_EQ(out.plane_force[0], direct.plane_force(0)) << k;
      EXPECT_EQ(out.probe_force[0], direct.probe_force(0)) << k;
    }
  EXPECT_GT(out.plane_vertices[0], 0) << "the plane reached the beam";
  EXPECT_GT(body.energy(), 0);
  EXPECT_EQ(body.unconverged_steps(), 0u);
  irdm::Probe rigid = probe;
  rigid.coupling_stiffness = 0;
  irdm::StepInput in;
  in.probes = &rigid, in.n_probes = 1;
  EXPECT_FALSE(body.step(in, out));
  EXPECT_NE(std::string(body.refusal()).find("virtual coupling"), std::string::npos);
  irdm::Plane plate = plane;
  plate.coupling_stiffness = 100;
  in        = {};
  in.planes = &plate, in.n_planes = 1;
  EXPECT_FALSE(body.step(in, out));
  EXPECT_NE(std::string(body.refusal()).find("plate coupling"), std::string::npos);
}

// The seed's split on the reduced body, in lockstep (the force loop at the deformation rate,
// each tick on the state just taken): the force loop's coupling force against the local
// compliance follows the coupling solved inside the Newton step.
TEST(ReducedRuntime, TheTwoLoopSplitFollowsTheImplicitCoupling)
{
  const irdm::ReducedNonlinearModel &m = reduced_beam();
  for (const double damping : {0.0, 0.5})
    {
      irdm::ReducedNonlinearBody implicit(m), split(m);
      irdm::LocalCompliance      local;
      double                     diff = 0, norm = 0;
      for (int k = 0; k < 100; ++k)
        {
          const irdm::ReducedProbe probe = tip_coupling(m, k, damping);
          ASSERT_TRUE(implicit.step(nullptr, 0, nullptr, 0, &probe, 1));
          irdm::CouplingTarget target;
          target.d = probe.target, target.d_dot = probe.target_velocity;
          target.stiffness = probe.stiffness, target.damping = probe.damping;
          const std::array<double, 3>    f = irdm::coupling_force(local, m.time_step * (k + 1), target);
          const irdm::ReducedVertexForce as_force{probe.vertices[0], f};
          ASSERT_TRUE(split.step(nullptr, 0, &as_force, 1));
          ASSERT_TRUE(split.point_state(probe.vertices.data(), probe.weights.data(), 1, local.u.data(),
                                        local.v.data(), local.a.data(), local.W.data()));
          local.step = k + 1, local.time = m.time_step * (k + 1), local.f = f;
          const auto &fi = implicit.probe_force(0);
          for (int d = 0; d < 3; ++d)
            diff += std::pow(f[d] - fi[d], 2), norm += fi[d] * fi[d];
        }
      const double error = std::sqrt(diff / norm);
      std::printf("coupling damping %g N s/m: the split's force against the implicit coupling's %.3g "
                  "(relative L2)\n", damping, error);
      EXPECT_LT(error, damping > 0 ? 0.05 : 0.07);
    }
}

// A free unit mass under the integrator's step, a unit force over one step alone: one step
// later it has moved c_1 times as far as at that step's end, and moves at e_1 times that over
// a step (by hand: Newmark's average acceleration 4 and 4; generalized alpha with rho_inf = 0.5,
// alpha_m = 0, alpha_f = 1/3, beta = 4/9, gamma = 5/6: x_1 = 8/27, x_2 = 28/27, v_2 = 17/18;
// rho_inf = 0.8, alpha_m = 1/3, alpha_f = 4/9, beta = 25/81, gamma = 11/18: x_1 = 125/486,
// x_2 = 1950/1944, v_2 = 71/72).
TEST(ReducedRuntime, TheInertialLagResponseIsAFreeMassOwn)
{
  const irdm::InertialLagResponse newmark = irdm::inertial_lag_response(0, 0, 0.25, 0.5);
  EXPECT_NEAR(newmark.c[0], 4, 1e-14);
  EXPECT_NEAR(newmark.e[0], 4, 1e-14);
  const irdm::InertialLagResponse alpha = irdm::inertial_lag_response(0, 1.0 / 3, 4.0 / 9, 5.0 / 6);
  EXPECT_NEAR(alpha.c[0], 3.5, 1e-14);
  EXPECT_NEAR(alpha.e[0], (17.0 / 18) / (8.0 / 27), 1e-14);
  const irdm::InertialLagResponse both = irdm::inertial_lag_response(1.0 / 3, 4.0 / 9, 25.0 / 81, 11.0 / 18);
  EXPECT_NEAR(both.c[0], 3.9, 1e-14);
  EXPECT_NEAR(both.e[0], (71.0 / 72) / (125.0 / 486), 1e-14);
}

// A point mass under Newmark's average acceleration, coupled by a spring to a device that
// pushes it: the split with its force loop one step behind (each window's ticks on the state
// of two steps before) is the coupling solved in the step, to round-off, once it answers for
// the force of the window between (inertia rules a free mass exactly); without, it is not.
TEST(ReducedRuntime, OneStepBehindTheForceLoopsAnswerIsExactOnAFreeMass)
{
  const double mass = 0.01, tau = 0.002, k = 50, beta = 0.25;
  const irdm::InertialLagResponse lag = irdm::inertial_lag_response(0, 0, beta, 0.5);
  const auto device = [](const double t) { return -0.002 * (1 - std::cos(M_PI * std::min(t / 0.06, 1.0))); };
  const auto split_error = [&](const bool answer) {
    double x = 0, v = 0, a = 0, xi = 0, vi = 0, ai = 0; // the split's mass, the implicit one's
    const double                         Wm = beta * tau * tau / mass; // one step's compliance
    irdm::LocalCompliance                rest; // at rest before the first step
    rest.W = {Wm, 0, 0, 0, Wm, 0, 0, 0, Wm}, rest.step = 0, rest.tau = tau;
    std::array<irdm::LocalCompliance, 2> published{rest, rest}; // [k % 2]: after step k - 1
    std::vector<std::array<double, 3>>   applied;
    double                               diff = 0, norm = 0;
    for (int n = 0; n < 60; ++n)
      {
        const double t = tau * (n + 1);
        // Implicit: f = k (d - x1), x1 = x + tau v + tau^2 (a / 4 + f / (4 m)).
        const double pred = xi + tau * vi + 0.25 * tau * tau * ai;
        const double fi   = k * (device(t) - pred) / (1 + k * Wm);
        const double ai1  = fi / mass;
        xi = pred + 0.25 * tau * tau * ai1, vi += 0.5 * tau * (ai + ai1), ai = ai1;
        // The split: the tick on the state after step n - 2.
        const irdm::LocalCompliance &c = published[(n + 1) % 2];
        irdm::CouplingTarget         target;
        target.d         = {0, 0, device(t)};
        target.stiffness = k;
        const long first = std::max<long long>(c.step, 0);
        const auto f = irdm::coupling_force(c, std::min(t, c.time + (irdm::InertialLagResponse::windows + 1) * tau),
                                            target, answer ? &lag : nullptr, applied.data() + first,
                                            static_cast<int>(n - first));
        applied.push_back(f);
        const double a1 = f[2] / mass;
        x += tau * v + 0.25 * tau * tau * (a + a1), v += 0.5 * tau * (a + a1), a = a1;
        irdm::LocalCompliance &next = published[(n + 1) % 2];
        next.u = {0, 0, x}, next.v = {0, 0, v}, next.a = {0, 0, a}, next.f = f;
        next.W = {Wm, 0, 0, 0, Wm, 0, 0, 0, Wm};
        next.step = n + 1, next.time = t, next.tau = tau;
        diff += std::pow(f[2] - fi, 2), norm += fi * fi;
      }
    return std::sqrt(diff / norm);
  };
  const double with = split_error(true), without = split_error(false);
  std::printf("one step behind, a free mass: the split against the coupling solved in the step %.3g "
              "with the lag's answer, %.3g without (relative L2)\n", with, without);
  EXPECT_LT(with, 1e-12);
  EXPECT_GT(without, 1e-3);
}

// The split with its force loop two steps behind (each window's ticks on the state of three
// steps before, its prediction held at two steps past it): without an answer for the force of
// the window between, which the state does not know of, the loop overshoots and grows; with the
// point's inertial lag response it stays near the coupling solved in the step (the tip's
// stiffness, which that response leaves out, is what is left). The bounds: the answer within
// 30 %, and ten times closer than without.
TEST(ReducedRuntime, AForceLoopTwoStepsBehindAnswersForTheForceBetween)
{
  const irdm::ReducedNonlinearModel &m   = reduced_beam();
  const irdm::InertialLagResponse    lag = irdm::inertial_lag_response(m.alpha_m, m.alpha_f, m.beta, m.gamma);
  const auto split_error = [&](const bool answer) {
    irdm::ReducedNonlinearBody               implicit(m), split(m);
    std::array<irdm::LocalCompliance, 3>     published; // [k % 3]: after step k - 1
    std::vector<std::array<double, 3>>       applied;
    double                                   diff = 0, norm = 0;
    for (int k = 0; k < 100; ++k)
      {
        irdm::ReducedProbe probe = tip_coupling(m, k, 0.5);
        probe.stiffness          = 50; // soft enough for the answer to hold: a stiffer coupling grows either way
        EXPECT_TRUE(implicit.step(nullptr, 0, nullptr, 0, &probe, 1));
        irdm::CouplingTarget target;
        target.d = probe.target, target.d_dot = probe.target_velocity;
        target.stiffness = probe.stiffness, target.damping = probe.damping;
        const irdm::LocalCompliance &c     = published[(k + 1) % 3]; // after step k - 3
        const long                   first = std::max<long long>(c.step, 0);
        const std::array<double, 3>  f     = irdm::coupling_force(
          c, std::min(m.time_step * (k + 1), c.time + (irdm::InertialLagResponse::windows + 1) * m.time_step),
          target, answer ? &lag : nullptr,
          applied.data() + first, static_cast<int>(k - first));
        applied.push_back(f);
        const irdm::ReducedVertexForce as_force{probe.vertices[0], f};
        EXPECT_TRUE(split.step(nullptr, 0, &as_force, 1));
        irdm::LocalCompliance &next = published[(k + 1) % 3];
        EXPECT_TRUE(split.point_state(probe.vertices.data(), probe.weights.data(), 1, next.u.data(),
                                      next.v.data(), next.a.data(), next.W.data()));
        next.step = k + 1, next.time = m.time_step * (k + 1), next.f = f, next.tau = m.time_step;
        const auto &fi = implicit.probe_force(0);
        for (int d = 0; d < 3; ++d)
          diff += std::pow(f[d] - fi[d], 2), norm += fi[d] * fi[d];
      }
    return std::sqrt(diff / norm);
  };
  const double with = split_error(true), without = split_error(false);
  std::printf("two steps behind: the split's force against the implicit coupling's %.3g with the "
              "lag's answer, %.3g without (relative L2)\n", with, without);
  EXPECT_LT(with, 0.3);
  EXPECT_GT(without, 10 * with);
}

// The residual's one-kernel element force is the law's and the damping's, added: on a
// stretched, sheared and turned tetrahedron with a velocity, to round-off; and both refuse an
// inverted one.
TEST(ReducedRuntime, TheDampedElementKernelIsTheSumOfItsParts)
{
  irdm::elastic::Tetrahedron t;
  const Eigen::Matrix3d      X = (Eigen::Matrix3d() << 0.01, 0, 0.002, 0, 0.012, 0, 0.001, 0.003, 0.009).finished();
  // Gradients of the four shape functions of the tetrahedron (0, X.col(0), X.col(1), X.col(2)).
  const Eigen::Matrix3d Xinv = X.inverse();
  t.grad.rightCols<3>()      = Xinv.transpose();
  t.grad.col(0)              = -t.grad.rightCols<3>().rowwise().sum();
  t.volume                   = std::abs(X.determinant()) / 6;
  std::mt19937                           gen(3);
  std::uniform_real_distribution<double> dist(-1, 1);
  irdm::elastic::Vector12                u, v, f, f_law, f_damping;
  for (int i = 0; i < 12; ++i)
    u(i) = 2e-3 * dist(gen), v(i) = 0.05 * dist(gen);
  const double mu = 700, lambda = 3000, beta = 0.004;
  ASSERT_TRUE(irdm::elastic::damped_neo_hookean_force(t, u, v, mu, lambda, beta, f));
  ASSERT_TRUE(irdm::elastic::neo_hookean_force(t, u, mu, lambda, f_law));
  irdm::elastic::objective_damping_force(t, u, v, mu, lambda, f_damping);
  const irdm::elastic::Vector12 sum = f_law + beta * f_damping;
  EXPECT_GT((beta * f_damping).norm(), 0.01 * f_law.norm()) << "both parts count";
  EXPECT_LT((f - sum).norm(), 1e-13 * sum.norm());
  irdm::elastic::Vector12 flat = irdm::elastic::Vector12::Zero();
  flat.segment<3>(3) = -2 * X.col(0); // node 1 through node 0: inverted
  EXPECT_FALSE(irdm::elastic::damped_neo_hookean_force(t, flat, v, mu, lambda, beta, f));
  EXPECT_FALSE(irdm::elastic::neo_hookean_force(t, flat, mu, lambda, f_law));
}

// The residual's four-lane element kernel (element_forces.h) against the one-element kernel:
// the weighted forces of random stretched and sheared tetrahedra (seven: the second group
// padded), added by vertex, to round-off of the force scale, with and without damping, the
// portable build and the AVX2 one; an inverted element counted and its force left out.
TEST(ReducedRuntime, TheFourLaneElementKernelIsTheOneElementKernel)
{
  std::mt19937                           gen(5);
  std::uniform_real_distribution<double> dist(-1, 1);
  constexpr unsigned                     n_vertices = 6;
  constexpr size_t                       n_elements = 7; // two groups, the second padded
  std::vector<irdm::elastic::Tetrahedron> elements(n_elements);
  std::vector<double>                     weights(n_elements);
  std::vector<std::array<unsigned, 4>>    vertices(n_elements);
  for (size_t k = 0; k < n_elements; ++k)
    {
      Eigen::Matrix3d X = 0.01 * Eigen::Matrix3d::Identity();
      for (int i = 0; i < 9; ++i)
        X(i / 3, i % 3) += 0.003 * dist(gen);
      const Eigen::Matrix3d Xinv = X.inverse();
      elements[k].grad.rightCols<3>() = Xinv.transpose();
      elements[k].grad.col(0)         = -elements[k].grad.rightCols<3>().rowwise().sum();
      elements[k].volume              = std::abs(X.determinant()) / 6;
      weights[k]                      = 1 + dist(gen);
      std::array<unsigned, 6> pick{0, 1, 2, 3, 4, 5};
      std::shuffle(pick.begin(), pick.end(), gen);
      vertices[k] = {pick[0], pick[1], pick[2], pick[3]};
    }
  Eigen::VectorXd u(3 * n_vertices), v(3 * n_vertices);
  for (Eigen::Index i = 0; i < u.size(); ++i)
    u(i) = 1e-3 * dist(gen), v(i) = 0.05 * dist(gen); // strains up to about 0.3: none inverted
  const auto groups = irdm::detail::pack_element_lanes(elements, weights, vertices);
  ASSERT_EQ(groups.size(), 2u);
  const double mu = 700, lambda = 3000;
  for (const double beta : {0.0, 0.004})
    for (const bool avx2 : {false, true})
      {
        if (avx2 && !detail::surface_product_avx2_available())
          continue;
        const auto kernel = avx2 ? detail::damped_neo_hookean_forces_avx2 : detail::damped_neo_hookean_forces_portable;
        // As the residual added them before: each element's one-kernel force times its weight.
        const auto expected = [&](const Eigen::VectorXd &uu, int &inverted) {
          Eigen::VectorXd f = Eigen::VectorXd::Zero(3 * n_vertices);
          inverted          = 0;
          for (size_t k = 0; k < n_elements; ++k)
            {
              irdm::elastic::Vector12 u_e, v_e, f_e;
              for (int a = 0; a < 4; ++a)
                u_e.segment<3>(3 * a) = uu.segment<3>(3 * vertices[k][a]), v_e.segment<3>(3 * a) = v.segment<3>(3 * vertices[k][a]);
              const bool ok = beta != 0 ? irdm::elastic::damped_neo_hookean_force(elements[k], u_e, v_e, mu, lambda, beta, f_e)
                                        : irdm::elastic::neo_hookean_force(elements[k], u_e, mu, lambda, f_e);
              if (!ok)
                {
                  ++inverted;
                  continue;
                }
              for (int a = 0; a < 4; ++a)
                f.segment<3>(3 * vertices[k][a]) += weights[k] * f_e.segment<3>(3 * a);
            }
          return f;
        };
        const char *name = avx2 ? "AVX2" : "portable";
        int         inverted = 0;
        Eigen::VectorXd f_ref = expected(u, inverted);
        ASSERT_EQ(inverted, 0);
        Eigen::VectorXd f = Eigen::VectorXd::Constant(3 * n_vertices, 0.25); // added to
        EXPECT_EQ(kernel(groups.data(), groups.size(), u.data(), v.data(), mu, lambda, beta, f.data()), 0u) << name;
        EXPECT_LT((f.array() - 0.25 - f_ref.array()).abs().maxCoeff(), 1e-12 * f_ref.lpNorm<Eigen::Infinity>())
          << name << ", beta " << beta;
        // Element 5 (the second group's second lane) turned inside out: counted, its force out.
        Eigen::VectorXd flat = u;
        const auto     &t5   = vertices[5];
        flat.segment<3>(3 * t5[1]) = flat.segment<3>(3 * t5[0]) - 2 * (elements[5].grad.rightCols<3>().transpose().inverse().col(0));
        f_ref = expected(flat, inverted);
        ASSERT_GE(inverted, 1) << "the test's inverted element";
        f.setZero();
        EXPECT_EQ(kernel(groups.data(), groups.size(), flat.data(), v.data(), mu, lambda, beta, f.data()), unsigned(inverted)) << name;
        EXPECT_LT((f - f_ref).lpNorm<Eigen::Infinity>(), 1e-12 * f_ref.lpNorm<Eigen::Infinity>()) << name << ", inverted";
      }
}

// Newton never calls a residual that is not finite converged (its stop is relative to the
// forces in the residual, which are then not finite too): a force that overflows the residual's
// norm fails the step, counted, and leaves the state finite. (A free body at 2 kPa once ran to
// 1e51 m in one step "converged" this way: full steps past a failed line search, each raising
// the residual, until it overflowed.)
TEST(ReducedRuntime, NewtonDoesNotConvergeOnAResidualThatIsNotFinite)
{
  const irdm::ReducedNonlinearModel &m = reduced_beam();
  irdm::ReducedNonlinearBody         body(m);
  const irdm::ReducedVertexForce     push{static_cast<unsigned>(m.surface_vertex.size() - 1), {0, 0, -1}};
  ASSERT_TRUE(body.step(nullptr, 0, &push, 1)) << "a newton's push converges";
  const irdm::ReducedVertexForce overflow{push.vertex, {0, 0, -1e200}}; // its square overflows
  EXPECT_FALSE(body.step(nullptr, 0, &overflow, 1));
  EXPECT_EQ(body.failed_steps(), 1u);
  EXPECT_TRUE(body.coordinates().allFinite());
}
