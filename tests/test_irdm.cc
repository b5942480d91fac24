// IRDM precompute and runtime against the reference FEM on a small mesh: the modal route equals
// stepping the FEM itself; untruncated IRDM reproduces the FEM's probe force and surface to
// round-off; the model loader rejects bad files; mpirun -np 2 gives the serial file's numbers.
#include <irdm/model.h>
#include <irdm/point_interaction.h>
#include <irdm_common/error.h>
#include <irdm_common/geometry.h>
#include <irdm_common/h5.h>
#include <reference_fem/elastodynamics.h>
#include <reference_fem/impulse_response.h>

#include <gtest/gtest.h>

#include "irdm_test_util.h"

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <new>
#include <fstream>
#include <map>

namespace fs = std::filesystem;
using namespace irdm;
using namespace irdm_test;

// Counts heap allocations while armed (irdm_test_util.h): the haptic step must make none.
bool g_count_allocations = false;
long g_allocations       = 0;
void *
operator new(std::size_t n)
{
  if (g_count_allocations)
    ++g_allocations;
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
  if (g_count_allocations)
    ++g_allocations;
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

TEST(Precompute, ModalRouteEqualsSteppingTheFem)
{
  const fem::Scene     scene = fem::parse_scene(beam_scene(""), ".");
  ImpulseResponseModel model = make_model(scene, "modal.h5");
  ASSERT_GT(model.n_inputs, 6u);
  // Step the FEM itself with a unit force sample on input DoF k (held during step 0, i.e. the
  // load at t = tau, zero at 0 and 2 tau) and compare every output at every step.
  double worst = 0, scale = 0;
  for (const unsigned k : {0u, 4u, model.n_inputs - 1})
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
      std::map<long long, unsigned> at;
      for (unsigned i = 0; i < r.surface.node_tags.size(); ++i)
        at[r.surface.node_tags[i]] = i;
      for (unsigned step = 0; step < model.length; ++step)
        for (unsigned j = 0; j < model.n_outputs; ++j)
          {
            const double fem_u = r.surface_displacement[step + 1][3 * at[model.output_node_tags[j / 3]] + j % 3];
            worst = std::max(worst, std::abs(fem_u - model.h(k, step, j)));
            scale = std::max(scale, std::abs(fem_u));
          }
    }
  EXPECT_GT(scale, 0);
  EXPECT_LT(worst / scale, 1e-9) << "modal H differs from stepping the FEM"; // measured 3.0e-10 (cond(K) of a slender beam)
}

TEST(Runtime, UntruncatedIrdmReproducesTheFem)
{
  const std::string probe = R"(, "probes": [{"name": "finger", "surface": "sides",
      "direction": [0, 0, -1], "unilateral": true,
      "path": {"times_s": [0, 0.2], "points_m": [[0.21, 0.001, 0.01], [0.235, -0.002, 0.01]]},
      "depth": {"times_s": [0, 0.05, 0.1, 0.12], "values_m": [0, 0.002, 0.002, -0.002]}}],
      "outputs": {"surface": true})";
  const fem::Scene     scene = fem::parse_scene(beam_scene(probe), ".");
  ImpulseResponseModel model = make_model(scene, "exact.h5");
  fem::ElasticDynamics fem(scene);
  const auto           r = fem.run();

  std::vector<unsigned>                 cand;
  std::vector<std::array<unsigned, 3>> tris;
  const int sides = static_cast<int>(std::find(model.surface_names.begin(), model.surface_names.end(), "sides") -
                                     model.surface_names.begin());
  for (unsigned t = 0; t < model.triangles.size(); ++t)
    if (model.triangle_surface[t] == sides)
      cand.push_back(t), tris.push_back(model.triangles[t]);
  std::map<long long, unsigned> at;
  for (unsigned i = 0; i < r.surface.node_tags.size(); ++i)
    at[r.surface.node_tags[i]] = i;

  PointInteraction    irdm(model);
  std::vector<double> u(model.n_outputs);
  double fmax = 0, ferr = 0, umax = 0, uerr = 0;
  int    switches = 0;
  bool   was_active = false;
  for (unsigned n = 0; n < scene.n_steps(); ++n)
    {
      const double t  = (n + 1) * scene.time_step;
      const auto  &p  = scene.probes[0];
      const auto   sp = geometry::closest_point(model.output_coordinates, tris, p.path.at(t));
      ProbeTarget  target;
      target.triangle = static_cast<int>(cand[sp.triangle]);
      target.weights  = sp.weights;
      for (int d = 0; d < 3; ++d)
        target.displacement[d] = p.depth.at(t) * p.direction[d];
      target.direction  = p.direction;
      target.unilateral = true;
      g_count_allocations = true;
      const bool stepped  = irdm.step(&target, 1);
      irdm.surface_displacement(u.data());
      g_count_allocations = false;
      ASSERT_TRUE(stepped);
      for (int d = 0; d < 3; ++d)
        {
          fmax = std::max(fmax, std::abs(r.probe_force.at("finger")[n + 1][d]));
          ferr = std::max(ferr, std::abs(irdm.force(0)[d] - r.probe_force.at("finger")[n + 1][d]));
        }
      switches += irdm.active(0) != was_active;
      was_active = irdm.active(0);
      for (unsigned j = 0; j < model.n_outputs; ++j)
        {
          const double fem_u = r.surface_displacement[n + 1][3 * at[model.output_node_tags[j / 3]] + j % 3];
          umax = std::max(umax, std::abs(fem_u));
          uerr = std::max(uerr, std::abs(u[j] - fem_u));
        }
    }
  EXPECT_EQ(g_allocations, 0) << "heap allocations inside step() / surface_displacement()";
  EXPECT_GT(fmax, 1e-4); // the probe did push
  EXPECT_GE(switches, 2); // it touched and let go
  EXPECT_LT(ferr / fmax, 1e-9);
  EXPECT_LT(uerr / umax, 1e-9);
  // Float storage costs float round-off, not more.
  const auto f = model.as_float();
  EXPECT_FALSE(f.double_storage);
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
  const std::string scene_file = tmp("mpi_scene.json");
  {
    std::ofstream f(scene_file);
    f << beam_scene("");
  }
  const std::string serial = tmp("serial.h5"), parallel = tmp("parallel.h5");
  // A clean environment: this test process is itself an MPI singleton, and its OMPI_*
  // variables would confuse a nested mpirun.
  const std::string clean = clean_environment();
  const std::string base  = std::string(IRDM_CLI) + " precompute " + scene_file +
                           " --quiet --restart --chunk 5 --out ";
  ASSERT_EQ(std::system((clean + base + serial + " > /dev/null").c_str()), 0);
  ASSERT_EQ(std::system((clean + "mpirun --allow-run-as-root --oversubscribe -np 2 " + base + parallel +
                         " > /dev/null").c_str()),
            0);
  const auto a = load_model(serial), b = load_model(parallel);
  ASSERT_EQ(a.h_double.size(), b.h_double.size());
  size_t differ = 0;
  for (size_t i = 0; i < a.h_double.size(); ++i)
    differ += a.h_double[i] != b.h_double[i];
  EXPECT_EQ(differ, 0u) << "entries of H that differ between 1 and 2 ranks";
  h5::Reader r(parallel);
  EXPECT_EQ(r.double_attribute("/", "precompute_ranks"), 2);
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
