#pragma once
// Internal to validation/: one scene run through the FEM or through any IRDM runtime
// (PointInteraction, RepresentativeInteraction, ModalInteraction: the same interface), and
// their comparison. Used by the point validation and the compression study.
#include <irdm/model.h>
#include <irdm/point_interaction.h>
#include <irdm_common/error.h>
#include <irdm_common/geometry.h>
#include <reference_fem/scene.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <string>
#include <vector>

namespace irdm::validation
{
  using Vec3 = std::array<double, 3>;

  inline double
  norm(const Vec3 &a)
  {
    return std::sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]);
  }

  // Samples k = 1..N of one run: probe forces and the displacement of the model's outputs.
  struct Series
  {
    std::vector<std::vector<Vec3>>   force;   // [probe][k-1]
    std::vector<std::vector<double>> surface; // [k-1][output DoF]
    double force_loop_seconds = 0, surface_seconds = 0, step_seconds = 0;
    double diverged_at = -1; // s; >= 0: the run was stopped there (force beyond the bound)
    // Passivity (energy) observer, summed over probes: W(n) = sum_{k<=n} f_k . (x_k - x_{k-1}),
    // the work the device (x: its displacement, the probe's depth along its direction) did on
    // the body and coupling up to step n. A passive body never gives back more than it took:
    // W(n) >= 0 throughout.
    double device_work     = 0; // J, W so far (at the end of the run: W(N))
    double device_returned = 0; // J, max over n of -W(n): > 0 means energy was created
    double device_work_max = 0; // J, max over n of W(n)
  };

  /// Mean lumped area (m^2, a third of each touching triangle's) of the model's free surface
  /// vertices: a penalty wall of p Pa/m is about p times this per vertex (N/m).
  inline double
  mean_free_vertex_area(const ModelFrame &m)
  {
    const std::vector<double> area = lumped_vertex_areas(m);
    double                    sum  = 0;
    unsigned                  n_free = 0;
    for (unsigned v = 0; v < area.size(); ++v)
      if (m.output_input_index[v] >= 0)
        sum += area[v], ++n_free;
    return sum / std::max(n_free, 1u);
  }

  /// Adds one step of the passivity observer: force f on the body (N) while the device moved
  /// from x_before to x (m).
  inline void
  observe_device_work(Series &s, const Vec3 &f, const Vec3 &x, const Vec3 &x_before)
  {
    s.device_work +=
      f[0] * (x[0] - x_before[0]) + f[1] * (x[1] - x_before[1]) + f[2] * (x[2] - x_before[2]);
    s.device_returned = std::max(s.device_returned, -s.device_work);
    s.device_work_max = std::max(s.device_work_max, s.device_work);
  }

  /// The device's displacement for probe p at time t (m): its depth along its direction.
  inline Vec3
  device_at(const fem::Probe &p, const double t)
  {
    const double depth = p.depth.at(t);
    return {depth * p.direction[0], depth * p.direction[1], depth * p.direction[2]};
  }

  struct Errors
  {
    double force_rel_l2 = 0, force_max = 0, disp_rms = 0, disp_max = 0;
    std::vector<double> force_t, disp_rms_t; // per sample, relative to the peaks
  };

  /// Errors of test against truth over the samples both have.
  Errors
  compare(const Series &test, const Series &truth);

  /// The largest probe force of a run (N).
  double
  peak_force(const Series &s);

  /// A device held to the body through a spring and a damper (virtual coupling), one solver
  /// at one setting: the coupling studies of the point and the plane validation.
  struct CouplingRun
  {
    double      k = 0, b = 0, tau = 0; // N/m, N s/m, s
    std::string solver;
    Series      s;
  };

  /// Bounded: never stopped, finite, and its peak force within 100 times reference_peak (N).
  bool
  coupling_bounded(const CouplingRun &r, double reference_peak);

  /// Passive: bounded, and the body gave back at most 1e-6 of the work the device put in (the
  /// passivity observer's round-off).
  bool
  coupling_passive(const CouplingRun &r, double reference_peak);

  /// coupling.csv: one row per run.
  std::string
  coupling_csv(const std::vector<CouplingRun> &runs, double reference_peak);

  /// A report cell: **P** passive, **B** bounded or **D** diverged, the peak force and the most
  /// energy given back.
  std::string
  coupling_cell(const CouplingRun &r, double reference_peak);

  /// FEM run at tau / refine; keeps the samples at t = k tau, k = 1..N, on the model outputs.
  /// Forces are averaged over the refine sub-steps of each tau (impulse per step / tau).
  Series
  run_fem(fem::Scene scene, const ModelFrame &model, unsigned refine, unsigned N);

  /// Per probe: the model triangles on its surface, and those triangles' vertices.
  struct ProbeSurfaces
  {
    std::vector<std::vector<unsigned>>                candidates;
    std::vector<std::vector<std::array<unsigned, 3>>> triangles;
  };
  ProbeSurfaces
  probe_surfaces(const fem::Scene &scene, const ModelFrame &model);

  /// IRDM run of the scene's probes with any runtime (step n is FEM time (n + 1) tau). Stops
  /// and sets diverged_at when a probe force is not finite or exceeds force_bound (N).
  template <class Interaction>
  Series
  run_irdm(const fem::Scene &scene, const ModelFrame &model, Interaction &irdm,
           const bool with_surface, const double force_bound = INFINITY)
  {
    using Clock            = std::chrono::steady_clock;
    const unsigned      N  = scene.n_steps();
    const int           P  = static_cast<int>(scene.probes.size());
    const ProbeSurfaces ps = probe_surfaces(scene, model);
    Series              s;
    std::vector<double> u(model.n_outputs);
    s.force.assign(P, {});
    std::array<ProbeTarget, contact::max_probes> targets;
    std::array<Vec3, contact::max_probes>        u_before{}; // probed points, last step
    unsigned n = 0;
    for (; n < N; ++n)
      {
        const double t = (n + 1) * scene.time_step;
        for (int p = 0; p < P; ++p)
          {
            const auto &pr = scene.probes[p];
            const auto  sp = geometry::closest_point(model.output_coordinates, ps.triangles[p], pr.path.at(t));
            targets[p].triangle = static_cast<int>(ps.candidates[p][sp.triangle]);
            targets[p].weights  = sp.weights;
            targets[p].n_patch  = 0;
            if (pr.radius > 0)
              {
                // The same patch the FEM spreads over (geometry::radius_patch).
                targets[p].n_patch = geometry::radius_patch(
                  model.output_coordinates, ps.triangles[p], sp.point, pr.radius,
                  targets[p].patch_vertices.data(), targets[p].patch_weights.data(),
                  contact::max_patch);
                if (targets[p].n_patch <= 0)
                  throw InputError("probe '" + pr.name + "': at t = " + std::to_string(t) +
                                   " s its radius_m covers " +
                                   (targets[p].n_patch == 0 ? "no model vertex" : "too many") +
                                   " (see probe-stiffness)");
              }
            // A rigid probe prescribes the device's displacement; a coupled one its target.
            const contact::Coupling coupling{pr.coupling_stiffness, pr.coupling_damping};
            targets[p].displacement = coupling.target(device_at(pr, t), device_at(pr, t - scene.time_step),
                                                      u_before[p], scene.time_step);
            targets[p].compliance = coupling.compliance(scene.time_step);
            targets[p].direction  = pr.direction;
            targets[p].unilateral = pr.unilateral;
            targets[p].present    = t <= pr.until;
          }
        const auto t0 = Clock::now();
        if (!irdm.step(targets.data(), P))
          throw InputError("scene '" + scene.name + "': at t = " + std::to_string(t) +
                           " s a probe touches a vertex that is not a model input; widen the "
                           "scene's model.inputs region");
        s.force_loop_seconds += std::chrono::duration<double>(Clock::now() - t0).count();
        bool bad = false;
        for (int p = 0; p < P; ++p)
          {
            u_before[p] = irdm.probe_displacement(p);
            observe_device_work(s, irdm.force(p), device_at(scene.probes[p], t),
                                device_at(scene.probes[p], t - scene.time_step));
            s.force[p].push_back(irdm.force(p));
            const double f = norm(irdm.force(p));
            bad            = bad || !std::isfinite(f) || f > force_bound;
          }
        if (with_surface)
          {
            const auto t1 = Clock::now();
            irdm.surface_displacement(u.data());
            s.surface_seconds += std::chrono::duration<double>(Clock::now() - t1).count();
            s.surface.push_back(u);
          }
        if (bad)
          {
            s.diverged_at = t;
            ++n;
            break;
          }
      }
    s.force_loop_seconds /= n;
    s.surface_seconds /= n;
    return s;
  }
} // namespace irdm::validation
