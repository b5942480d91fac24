// A minimal haptic application on the installed IRDM runtime (docs/runtime-api.md):
// load a model, run the force loop in one thread and the surface update in another, sharing
// the state through the lock-free triple buffer.
//
//   haptic_loop MODEL.h5 [steps] [depth_m]
//
// The probe presses the model's first vertex it can push along -z by depth_m (ramped over the first
// half of the run) and holds. Not real time: the point is the API. At the end it prints the
// probe force and how far the surface the deformation thread computed at the probed vertex is
// from the prescribed displacement (the surface update uses every mode, so this is the float
// rounding of the stored surface shapes).
#include <irdm/irdm.h>
#include <irdm/surface_exchange.h>

#include <atomic>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <thread>
#include <vector>

int
main(int argc, char **argv)
{
  if (argc < 2 || std::string(argv[1]) == "--help")
    {
      std::printf("usage: haptic_loop MODEL.h5 [steps] [depth_m]\n");
      return argc < 2 ? 2 : 0;
    }
  const long   steps = argc > 2 ? std::atol(argv[2]) : 500;
  const double depth = argc > 3 ? std::atof(argv[3]) : 1e-3; // m
  if (steps < 2 || !(depth >= 0))
    {
      std::fprintf(stderr, "haptic_loop: steps must be >= 2 and depth_m >= 0\n");
      return 2;
    }
  try
    {
      // Loading the model and making the body allocate: do both before the loops start.
      irdm::ModelOptions options;
      options.surface_modes = 0; // every mode: the exact surface
      const irdm::Model model = irdm::Model::load(argv[1], options);
      irdm::Body        body(model);
      const auto       &rest = model.rest_positions();
      unsigned          vertex = 0;
      while (vertex < rest.size() && !model.can_push(vertex))
        ++vertex;
      if (vertex == rest.size())
        throw irdm::InputError("the model has no input vertex to probe");

      irdm::Probe probe;
      probe.n_patch           = 1;
      probe.patch_vertices[0] = vertex;
      probe.patch_weights[0]  = 1;
      irdm::StepInput input;
      input.probes   = &probe;
      input.n_probes = 1;
      irdm::StepOutput output;

      irdm::TripleBuffer<irdm::SurfaceState> exchange(model.make_surface_state());
      std::atomic<bool>                      done{false};
      std::vector<double>                    prescribed_z(steps);
      bool                                   refused = false;

      // Force thread: one step per tick (a real application sleeps to each deadline).
      std::thread force([&] {
        for (long n = 0; n < steps && !refused; ++n)
          {
            probe.displacement = {0, 0, -depth * std::min(1.0, 2.0 * (n + 1) / steps)};
            prescribed_z[n]    = probe.displacement[2];
            refused            = !body.step(input, output);
            body.save_surface_state(exchange.back());
            exchange.publish();
          }
        done.store(true, std::memory_order_release);
      });
      // Deformation thread: the newest state, whenever one arrived.
      std::vector<double> x(3 * rest.size());
      long long           last_step = 0;
      long                updates   = 0;
      std::thread         deformation([&] {
        for (;;)
          {
            const bool finished = done.load(std::memory_order_acquire);
            if (exchange.update())
              {
                model.surface_positions(exchange.front(), x.data());
                last_step = exchange.front().steps;
                ++updates;
              }
            else if (finished)
              break;
          }
      });
      force.join();
      deformation.join();

      if (refused || last_step < 1)
        {
          std::fprintf(stderr, "haptic_loop: a step was refused: %s\n", body.refusal());
          return 3;
        }
      const double error =
        std::abs(x[3 * vertex + 2] - rest[vertex][2] - prescribed_z[last_step - 1]);
      std::printf("steps %lld, surface updates %ld\n", last_step, updates);
      std::printf("probe force on the body (N): %.6g %.6g %.6g\n", output.probe_force[0][0],
                  output.probe_force[0][1], output.probe_force[0][2]);
      std::printf("probe vertex displacement error (m): %.3g\n", error);
      // The surface shapes are stored in float (eps 6e-8): the surface meets the prescribed
      // displacement to that rounding, not to double round-off.
      return error <= 1e-6 * std::max(depth, 1e-12) + 1e-15 ? 0 : 3;
    }
  catch (const irdm::InputError &e)
    {
      std::fprintf(stderr, "haptic_loop: error: %s\n", e.what());
      return 2;
    }
}
