// The two asynchronous loops (irdm/surface_exchange.h): a force thread steps a modal runtime
// and publishes its state; a deformation thread takes the newest state and updates the
// surface. Every surface the deformation thread computes must equal, bit for bit, the surface
// of the same step computed in one thread (no torn or stale-mixed state), the steps it sees
// must only increase, and it must see the last one. No deal.II and no FEM: the model is a
// small synthetic modal realization, so that this test builds and runs under ThreadSanitizer
// (scripts/tsan.sh), which checks that the exchange has no data race.
#include <irdm/modal_model.h>
#include <irdm/surface_exchange.h>
#include <irdm_common/error.h>

#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <random>
#include <thread>
#include <vector>

using namespace irdm;

namespace
{
  // Four vertices, all inputs and outputs; six modes, three of them in the surface update. The
  // numbers are arbitrary but fixed (the test checks the exchange, not the physics); the
  // step matrices are contractive so the state stays bounded.
  ModalModel
  synthetic_model()
  {
    ModalModel m;
    m.time_step = 1e-3;
    m.length    = 1;
    m.n_inputs = m.n_outputs = 12;
    m.n_modes                = 6;
    m.surface_modes          = 3;
    m.force_modes            = 6;
    m.output_coordinates     = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {1, 1, 0}};
    m.output_node_tags       = {1, 2, 3, 4};
    m.input_node_tags        = {1, 2, 3, 4};
    m.input_output_index     = {0, 1, 2, 3};
    m.output_input_index     = {0, 1, 2, 3};
    m.triangles              = {{0, 1, 2}, {1, 3, 2}};
    m.triangle_surface       = {0, 0};
    m.surface_names          = {"top"};
    std::mt19937                           rng(7);
    std::uniform_real_distribution<double> uniform(-1, 1);
    m.input_shapes.resize(12 * 6);
    for (double &x : m.input_shapes)
      x = uniform(rng);
    m.shapes.resize(12 * 3);
    for (unsigned j = 0; j < 12; ++j)
      for (unsigned i = 0; i < 3; ++i)
        m.shapes[j * 3 + i] = static_cast<float>(m.input_shapes[j * 6 + i]);
    m.step.assign(6 * 15, 0.0);
    for (unsigned i = 0; i < 6; ++i)
      {
        double *s = &m.step[15 * i]; // rows (u, v, a): [A (3) | b_new | b_old]
        s[0] = 0.95, s[1] = 1e-3, s[3] = 1e-4 * (i + 1), s[4] = 5e-5;
        s[5 + 1] = 0.9, s[5 + 2] = 1e-3, s[5 + 3] = 1e-2, s[5 + 4] = 5e-3;
        s[10 + 2] = 0.5, s[10 + 3] = 1.0, s[10 + 4] = 0.5;
      }
    m.h0_inputs.assign(12 * 12, 0.0);
    for (unsigned k = 0; k < 12; ++k)
      m.h0_inputs[k * 12 + k] = 1e-3 * (1 + 0.1 * k);
    m.residual.resize(12 * 12);
    for (float &x : m.residual)
      x = static_cast<float>(1e-5 * uniform(rng));
    return m;
  }

  ProbeTarget
  probe_at(const long long step)
  {
    ProbeTarget p;
    p.n_patch           = 1;
    p.patch_vertices[0] = 3;
    p.patch_weights[0]  = 1;
    p.displacement      = {0, 0, -1e-3 * std::sin(0.01 * static_cast<double>(step))};
    return p;
  }
} // namespace

TEST(TwoLoops, DeformationThreadSeesWholeStatesInOrderAndTheLast)
{
  const ModalModel model = synthetic_model();
  const long long  n_steps = 20000;
  const unsigned   nout    = model.n_outputs;

  TripleBuffer<ModalSurfaceState> exchange(make_surface_state(model));
  std::atomic<bool>               done{false};

  // Force thread: (warm-up, as irdm play's does while it waits for its tick), step, save the
  // state into the back slot, publish. The replay below has no warm-up: it changes nothing.
  std::thread force([&] {
    ModalInteraction runtime(model);
    for (long long n = 0; n < n_steps; ++n)
      {
        runtime.warm_step();
        const ProbeTarget p = probe_at(n);
        runtime.step(&p, 1);
        runtime.save_surface_state(exchange.back());
        exchange.publish();
      }
    done.store(true, std::memory_order_release);
  });

  // Deformation thread: the newest state whenever one arrived; buffers sized before the loop.
  const size_t           capacity = n_steps + 1; // room for every state: never reallocates
  std::vector<long long> seen_steps;
  std::vector<double>    seen_surfaces(capacity * nout);
  seen_steps.reserve(capacity);
  std::thread deformation([&] {
    std::vector<double> u(nout);
    for (size_t part = 0;; part = (part + 1) % 4)
      {
        // Reads the model only, while the force thread runs; a piece at a time, as irdm
        // play's deformation thread keeps the shapes warm until its frame.
        warm_surface(model, part, 4);
        const bool finished = done.load(std::memory_order_acquire);
        if (exchange.update())
          {
            surface_displacement(model, exchange.front(), u.data());
            std::copy(u.begin(), u.end(), &seen_surfaces[seen_steps.size() * nout]);
            seen_steps.push_back(exchange.front().steps);
          }
        else if (finished) // done follows the last publish: nothing newer can come
          break;
      }
  });
  force.join();
  deformation.join();

  ASSERT_FALSE(seen_steps.empty());
  EXPECT_EQ(seen_steps.back(), n_steps) << "the deformation thread must see the last step";
  for (size_t i = 1; i < seen_steps.size(); ++i)
    ASSERT_GT(seen_steps[i], seen_steps[i - 1]) << "states out of order at sample " << i;

  // The same steps in one thread: every surface seen must be that step's, exactly.
  ModalInteraction    replay(model);
  std::vector<double> u(nout);
  size_t              next = 0, checked = 0;
  for (long long n = 0; n < n_steps && next < seen_steps.size(); ++n)
    {
      const ProbeTarget p = probe_at(n);
      replay.step(&p, 1);
      if (replay.steps() != seen_steps[next])
        continue;
      replay.surface_displacement(u.data());
      for (unsigned j = 0; j < nout; ++j)
        ASSERT_EQ(u[j], seen_surfaces[next * nout + j]) << "step " << seen_steps[next];
      ++next, ++checked;
    }
  EXPECT_EQ(checked, seen_steps.size());
  EXPECT_GT(std::abs(u[11]), 0.0) << "the probe must move the surface";
  std::printf("deformation thread saw %zu of %lld states\n", seen_steps.size(), n_steps);
}

TEST(TwoLoops, SurfaceWarmUpRefusesAPieceOutsideItsParts)
{
  const ModalModel model = synthetic_model();
  EXPECT_NO_THROW(warm_surface(model, 0, 1));
  EXPECT_NO_THROW(warm_surface(model, 5, 6));
  EXPECT_THROW(warm_surface(model, 6, 6), InputError);
  EXPECT_THROW(warm_surface(model, 0, 0), InputError);
}
