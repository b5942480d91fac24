// irdm play with a reduced nonlinear model (docs/reduced-model.md, "Two loops"): the seed's
// split on the reduced body.
//
//   force thread        every 1 / rate: the device's virtual-coupling force against the newest
//                       local compliance of the probed point (irdm/reduced_force_loop.h, a
//                       3 x 3 solve), recorded; then the tick counts as done.
//   deformation thread  per tau of trajectory time, once the force loop has done that window's
//                       ticks: one Newton step of the reduced body with the mean of the
//                       window's forces on the probed vertex, then the point's local
//                       compliance, published through a triple buffer.
//
// The device is coupled to one surface vertex by a spring and a damper while its tip is
// behind the rest surface along the vertex normal (its target: the tip's motion since it
// crossed), unilateral. The trajectory plays in real time; where the deformation loop falls
// behind, the force loop works on an older state (its lag is measured), adds the answer to the
// latest window's force that the state does not hold (irdm/reduced_force_loop.h), and holds
// its prediction at two steps past the state. Nothing in either loop allocates or locks.
#include "play.h"
#include "play_realtime.h"

#include <irdm/reduced_force_loop.h>
#include <irdm/reduced_nonlinear.h>
#include <irdm/surface_exchange.h>
#include <irdm_common/csv.h>
#include <irdm_common/error.h>
#include <irdm_common/files.h>
#include <irdm_common/format.h>
#include <irdm_common/report_stamp.h>
#include <irdm_common/report_template.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <filesystem>
#include <thread>

#include <sys/mman.h>

namespace irdm::play
{
  namespace
  {
    namespace fs = std::filesystem;

    /// The run: the model, the probed vertex, and every force tick's coupling target.
    struct ReducedSetup
    {
      Trajectory            trajectory;
      ReducedNonlinearModel model;
      ReducedBodyOptions    options; // every body's: the Newton stop of --newton-tolerance
      double                tau = 0, rate = 0, duration = 0;
      long                  n_ticks = 0, n_steps = 0;
      unsigned              vertex = 0; // into the model's surface
      Vec3                  normal{}, rest{};
      std::vector<CouplingTarget> targets; // per tick
      std::vector<double>         present; // per tick, 0 or 1
      std::vector<long>           window_end; // per deformation step: its last tick + 1
      InertialLagResponse         lag_response; // the model's integrator's
    };

    /// The probed vertex (given, or the free surface vertex nearest the first sample) and
    /// every tick's target: the device's motion since it crossed the rest surface while behind
    /// it, pushing along the inward normal.
    void
    prepare_reduced(ReducedSetup &s, const PlayOptions &o, std::ostream &out)
    {
      if (!(o.coupling_stiffness > 0))
        throw InputError("play: a reduced nonlinear model is probed through a virtual coupling: give "
                         "--coupling-stiffness (N/m, > 0)");
      s.trajectory = read_trajectory(o.trajectory);
      if (!o.quiet)
        out << "loading " << o.model << "\n" << std::flush;
      s.model = load_reduced_nonlinear_model(o.model);
      s.options.tolerance     = o.newton_tolerance;
      s.options.tangent_steps = o.tangent_steps;
      if (s.model.rigid_modes > 0)
        throw InputError("play: '" + o.model + "' is a free body's reduced model; play runs a "
                         "grounded one (a free one runs in irdm validate-free)");
      s.tau   = s.model.time_step;
      s.lag_response = inertial_lag_response(s.model.alpha_m, s.model.alpha_f, s.model.beta, s.model.gamma);
      s.rate  = o.rate_hz > 0 ? o.rate_hz : 1 / s.tau;
      if (s.rate > 100000)
        throw InputError("--rate-hz must be at most 100000");
      const auto &X = s.model.coordinates;
      if (o.vertex >= 0)
        {
          if (o.vertex >= static_cast<long>(X.size()))
            throw InputError("--vertex " + std::to_string(o.vertex) + " is not a surface vertex of the model (" +
                             std::to_string(X.size()) + ")");
          s.vertex = static_cast<unsigned>(o.vertex);
        }
      else
        {
          double best = INFINITY;
          for (unsigned v = 0; v < X.size(); ++v)
            if (s.model.free_dof[v][0] || s.model.free_dof[v][1] || s.model.free_dof[v][2])
              {
                const double d = std::hypot(X[v][0] - s.trajectory.tip[0][0], X[v][1] - s.trajectory.tip[0][1],
                                            X[v][2] - s.trajectory.tip[0][2]);
                if (d < best)
                  best = d, s.vertex = v;
              }
        }
      s.normal   = outward_normal(s.model.coordinates, s.model.triangles, s.vertex);
      s.rest     = X[s.vertex];
      s.duration = s.trajectory.time.back() - s.trajectory.time.front();
      s.n_steps  = static_cast<long>(std::floor(s.duration / s.tau + 1e-9));
      s.n_ticks  = static_cast<long>(std::floor(s.duration * s.rate + 1e-9));
      if (s.n_steps < 1 || s.n_ticks < 1)
        throw InputError("--trajectory: shorter than one model step (" + fmt(s.tau) + " s)");
      s.targets.resize(s.n_ticks);
      s.present.resize(s.n_ticks);
      Vec3 touch{0, 0, 0}, before{0, 0, 0};
      for (long n = 0; n < s.n_ticks; ++n)
        {
          const Vec3 tip   = tip_at(s.trajectory, s.trajectory.time.front() + (n + 1) / s.rate);
          double     depth = 0;
          for (int d = 0; d < 3; ++d)
            depth -= (tip[d] - s.rest[d]) * s.normal[d];
          const bool present = depth > 0;
          if (present && (n == 0 || s.present[n - 1] == 0))
            for (int d = 0; d < 3; ++d)
              touch[d] = tip[d] + depth * s.normal[d];
          CouplingTarget &t = s.targets[n];
          for (int d = 0; d < 3; ++d)
            {
              t.d[d]         = present ? tip[d] - touch[d] : 0;
              t.d_dot[d]     = present && n > 0 && s.present[n - 1] ? (t.d[d] - before[d]) * s.rate : 0;
              t.direction[d] = -s.normal[d];
            }
          t.stiffness  = o.coupling_stiffness;
          t.damping    = o.coupling_damping;
          t.unilateral = true;
          s.present[n] = present;
          before       = t.d;
        }
      // Deformation step k covers trajectory time (k tau, (k + 1) tau]: the ticks at or before
      // its end.
      s.window_end.resize(s.n_steps);
      for (long k = 0; k < s.n_steps; ++k)
        s.window_end[k] = std::min(s.n_ticks, static_cast<long>(std::floor((k + 1) * s.tau * s.rate + 1e-9)));
    }

    /// The mean force of ticks [from, to) (N); a window without a tick (a force loop slower
    /// than the deformation loop) holds the force before it.
    Vec3
    mean_force(const std::vector<Vec3> &force, const long from, const long to, const Vec3 &before)
    {
      if (to <= from)
        return before;
      Vec3 f{0, 0, 0};
      for (long n = from; n < to; ++n)
        for (int d = 0; d < 3; ++d)
          f[d] += force[n][d] / static_cast<double>(to - from);
      return f;
    }

    /// Step k of a deformation loop: the body with the window's mean force, then the local
    /// compliance it publishes.
    bool
    deformation_step(ReducedNonlinearBody &body, const ReducedSetup &s, const long k, const Vec3 &f,
                     LocalCompliance &c)
    {
      const ReducedVertexForce force{s.vertex, f};
      body.step(nullptr, 0, &force, 1);
      const double weight = 1;
      c.step = k + 1, c.time = (k + 1) * s.tau, c.f = f, c.tau = s.tau;
      return body.point_state(&s.vertex, &weight, 1, c.u.data(), c.v.data(), c.a.data(), c.W.data());
    }

    /// The force loop's time for tick n against state c: the tick's, held at the windows
    /// the lag's answer covers and one more past the state (a deformation loop far behind gives
    /// no extrapolation over its lag).
    double
    predicted_time(const ReducedSetup &s, const long n, const LocalCompliance &c)
    {
      return std::min((n + 1) / s.rate, c.time + (InertialLagResponse::windows + 1) * s.tau);
    }

    /// The force deformation step i is taken with, from the ticks' forces: its window's mean,
    /// or, for a window without a tick, that of the latest window before it with one (none: 0).
    Vec3
    window_force(const ReducedSetup &s, const std::vector<Vec3> &force, const long i)
    {
      for (long j = i; j >= 0; --j)
        if (const long from = j > 0 ? s.window_end[j - 1] : 0; from < s.window_end[j])
          return mean_force(force, from, s.window_end[j], Vec3{0, 0, 0});
      return {0, 0, 0};
    }

    /// Tick n's coupling force against state c, tick n in window w (w = n_steps: after the last
    /// window), `force` the ticks' forces so far: the latest InertialLagResponse::windows of the
    /// windows between c and w answered, each with the force its deformation step is taken with.
    Vec3
    tick_force(const ReducedSetup &s, const long n, const long w, const LocalCompliance &c, const std::vector<Vec3> &force)
    {
      if (s.present[n] <= 0)
        return {0, 0, 0};
      std::array<Vec3, InertialLagResponse::windows> since{};
      const long first = static_cast<long>(std::max({c.step, static_cast<long long>(w) - InertialLagResponse::windows, 0LL}));
      int        n_since = 0;
      for (long i = first; i < w; ++i)
        since[n_since++] = window_force(s, force, i);
      return coupling_force(c, predicted_time(s, n, c), s.targets[n], &s.lag_response, since.data(), n_since);
    }

    struct ReducedRecords
    {
      std::vector<Vec3>   force;                       // per tick, N
      std::vector<double> force_us, late_us;           // per tick
      std::vector<double> step_us, lag_ms, iterations; // per deformation step
      std::vector<double> tangents, staged_tangents;   // per deformation step: made in it, taken into use
      std::vector<Vec3>   step_force;                  // per deformation step, N
      std::vector<Vec3>   probed_u;                    // per deformation step, m
      long                missed = 0;
      std::string         force_rt, deformation_rt;
      Interruptions       force_seen;

      explicit ReducedRecords(const ReducedSetup &s)
        : force(s.n_ticks), force_us(s.n_ticks), late_us(s.n_ticks), step_us(s.n_steps),
          lag_ms(s.n_steps), iterations(s.n_steps), tangents(s.n_steps), staged_tangents(s.n_steps),
          step_force(s.n_steps), probed_u(s.n_steps),
          force_seen(static_cast<size_t>(s.n_ticks) * 4)
      {}
    };

    /// The two loops in real time.
    void
    run_reduced_loops(const ReducedSetup &s, ReducedRecords &r, const PlayOptions &o, ReducedNonlinearBody &body)
    {
      const int                   cpus = static_cast<int>(std::thread::hardware_concurrency());
      const std::int64_t          period_ns = std::llround(1e9 / s.rate);
      const std::int64_t          spin_ns   = std::llround(1e3 * (o.spin_us < 0 ? 0.9e6 / s.rate : std::min(o.spin_us, 1e6 / s.rate)));
      TripleBuffer<LocalCompliance> exchange{LocalCompliance{}};
      std::atomic<long>             ticks_done{0};
      std::atomic<int>              ready{0};
      std::atomic<std::int64_t>     start_at{0};
      const auto                    wait_for_start = [&] {
        if (ready.fetch_add(1) + 1 == 2)
          start_at.store(now_ns() + 10000000, std::memory_order_release);
        std::int64_t t;
        while ((t = start_at.load(std::memory_order_acquire)) == 0)
          std::this_thread::sleep_for(std::chrono::microseconds(100));
        return t;
      };
      std::thread force([&] {
        r.force_rt               = make_real_time(o.pin && cpus > 1 ? cpus - 1 : -1, 80);
        const std::int64_t start = wait_for_start();
        long window = 0;
        for (long n = 0; n < s.n_ticks; ++n)
          {
            while (window < s.n_steps && s.window_end[window] <= n) // n_steps: after the last window
              ++window;
            const std::int64_t deadline = start + n * period_ns;
            const std::int64_t wake     = wait_for_tick(deadline, spin_ns, [] {}, r.force_seen);
            exchange.update();
            const LocalCompliance &c = exchange.front();
            r.force[n]               = tick_force(s, n, window, c, r.force);
            ticks_done.store(n + 1, std::memory_order_release);
            const std::int64_t done = now_ns();
            r.force_us[n]           = 1e-3 * static_cast<double>(done - wake);
            r.late_us[n]            = 1e-3 * static_cast<double>(wake - deadline);
            r.missed += done > deadline + period_ns;
          }
      });
      std::thread deformation([&] {
        r.deformation_rt         = make_real_time(o.pin && cpus > 1 ? 0 : -1, 70);
        const std::int64_t start = wait_for_start();
        long               from  = 0;
        for (long k = 0; k < s.n_steps; ++k)
          {
            const long to = s.window_end[k];
            while (ticks_done.load(std::memory_order_acquire) < to)
              std::this_thread::sleep_for(std::chrono::microseconds(20));
            const unsigned long made = body.tangent_evaluations(), staged = body.staged_tangent_evaluations();
            const std::int64_t  t0   = now_ns();
            r.step_force[k]       = mean_force(r.force, from, to, k > 0 ? r.step_force[k - 1] : Vec3{0, 0, 0});
            deformation_step(body, s, k, r.step_force[k], exchange.back());
            r.probed_u[k] = exchange.back().u;
            exchange.publish();
            const std::int64_t t1 = now_ns();
            r.step_us[k]          = 1e-3 * static_cast<double>(t1 - t0);
            r.lag_ms[k]           = 1e-6 * static_cast<double>(t1 - (start + to * period_ns));
            r.iterations[k]       = body.newton_iterations();
            r.tangents[k]         = static_cast<double>(body.tangent_evaluations() - made);
            r.staged_tangents[k]  = static_cast<double>(body.staged_tangent_evaluations() - staged);
            from                  = to;
          }
      });
      force.join();
      deformation.join();
    }

    /// The same split offline in lockstep (each window's ticks on the state just before it,
    /// no lag), the split with its force loop on states a given number of steps older, and
    /// the coupling solved inside the Newton step at the deformation rate (one loop, the
    /// reference): each one's force per deformation step (N).
    struct LaggedSplit
    {
      unsigned          lag = 0; // deformation steps
      std::vector<Vec3> force;
      unsigned long     failed = 0, cut = 0;
      unsigned          most_iterations = 0;
    };
    struct OfflineForces
    {
      std::vector<Vec3>        lockstep, implicit;
      std::vector<LaggedSplit> lagged;
    };

    /// The split offline: each window's ticks on the state published `lag` steps before the
    /// one just before it (lag 0: lockstep).
    LaggedSplit
    split_forces(const ReducedSetup &s, const unsigned lag)
    {
      LaggedSplit                  r{lag, std::vector<Vec3>(s.n_steps)};
      ReducedNonlinearBody         body(s.model, s.options);
      std::vector<LocalCompliance> published(lag + 1); // [k % (lag + 1)]: after step k - 1
      std::vector<Vec3>            tick(s.n_ticks);
      long                         from = 0;
      for (long k = 0; k < s.n_steps; ++k)
        {
          const long             to = s.window_end[k];
          const LocalCompliance &c  = published[(k + 1) % (lag + 1)]; // after step k - 1 - lag
          for (long n = from; n < to; ++n)
            tick[n] = tick_force(s, n, k, c, tick);
          r.force[k] = mean_force(tick, from, to, k > 0 ? r.force[k - 1] : Vec3{0, 0, 0});
          deformation_step(body, s, k, r.force[k], published[(k + 1) % (lag + 1)]);
          r.most_iterations = std::max(r.most_iterations, body.newton_iterations());
          from              = to;
        }
      r.failed = body.failed_steps(), r.cut = body.cut_steps();
      return r;
    }

    OfflineForces
    offline_forces(const ReducedSetup &s, const std::vector<unsigned> &lags)
    {
      OfflineForces f{{}, std::vector<Vec3>(s.n_steps), {split_forces(s, 0)}};
      f.lockstep = f.lagged[0].force;
      for (const unsigned lag : lags)
        f.lagged.push_back(split_forces(s, lag));
      ReducedNonlinearBody one_loop(s.model, s.options);
      for (long k = 0; k < s.n_steps; ++k)
        {
          const long   to = s.window_end[k];
          ReducedProbe probe;
          probe.n_patch     = 1;
          probe.vertices[0] = s.vertex;
          probe.weights[0]  = 1;
          const CouplingTarget &t = s.targets[std::max(to - 1, 0L)];
          probe.target = t.d, probe.target_velocity = t.d_dot, probe.direction = t.direction;
          probe.stiffness = t.stiffness, probe.damping = t.damping, probe.unilateral = true;
          const bool present = to > 0 && s.present[to - 1] > 0;
          one_loop.step(nullptr, 0, nullptr, 0, &probe, present ? 1 : 0);
          f.implicit[k] = present ? one_loop.probe_force(0) : Vec3{0, 0, 0};
        }
      return f;
    }

    std::vector<double>
    component(const std::vector<Vec3> &x, const int d)
    {
      std::vector<double> c(x.size());
      for (size_t k = 0; k < x.size(); ++k)
        c[k] = x[k][d];
      return c;
    }

    /// lag.csv: per lag of the offline split (0 first), its force's distance from the coupling
    /// solved in the step and from the lockstep split, its peak, and its Newton's counts; and
    /// the same in a sentence for play.md.
    std::string
    write_lag_table(const fs::path &path, const ReducedSetup &s, const OfflineForces &offline)
    {
      std::vector<double> lag, lag_ms, error, from_lockstep, peak, failed, cut, iterations;
      std::string         text;
      for (const LaggedSplit &l : offline.lagged)
        {
          double p = 0;
          for (const Vec3 &f : l.force)
            p = std::max(p, std::hypot(f[0], f[1], f[2]));
          lag.push_back(l.lag), lag_ms.push_back(1e3 * l.lag * s.tau);
          error.push_back(relative_l2(l.force, offline.implicit));
          from_lockstep.push_back(relative_l2(l.force, offline.lockstep));
          peak.push_back(p), failed.push_back(static_cast<double>(l.failed));
          cut.push_back(static_cast<double>(l.cut)), iterations.push_back(l.most_iterations);
          text += (text.empty() ? "" : "; ") + std::to_string(l.lag) + " (" + fmt(lag_ms.back()) + " ms) " +
                  fmt(error.back()) + ", peak " + fmt(p) + " N";
        }
      write_csv(path.string(),
                {"lag_steps", "lag_ms", "force_error", "lockstep_difference", "peak_force_N", "failed_steps",
                 "cut_steps", "most_newton_iterations"},
                {lag, lag_ms, error, from_lockstep, peak, failed, cut, iterations});
      return text;
    }

    /// forces.csv (per tick), deformation.csv (per deformation step), summary.csv and play.md.
    int
    write_reduced_outputs(const fs::path &dir, const ReducedSetup &s, const ReducedRecords &r,
                          const PlayOptions &o, const ReducedNonlinearBody &body, const OfflineForces *offline,
                          std::ostream &out)
    {
      std::vector<double> tick(s.n_ticks), time(s.n_ticks), step(s.n_steps), step_time(s.n_steps);
      std::vector<Vec3>   device(s.n_ticks);
      for (long n = 0; n < s.n_ticks; ++n)
        {
          tick[n] = static_cast<double>(n), time[n] = (n + 1) / s.rate;
          for (int d = 0; d < 3; ++d)
            device[n][d] = s.rest[d] + s.targets[n].d[d];
        }
      for (long k = 0; k < s.n_steps; ++k)
        step[k] = static_cast<double>(k), step_time[k] = (k + 1) * s.tau;
      write_csv((dir / "forces.csv").string(),
                {"step", "time_s", "device_x_m", "device_y_m", "device_z_m", "present", "force_x_N",
                 "force_y_N", "force_z_N", "force_step_us", "wake_late_us"},
                {tick, time, component(device, 0), component(device, 1), component(device, 2), s.present,
                 component(r.force, 0), component(r.force, 1), component(r.force, 2), r.force_us, r.late_us});
      write_csv((dir / "deformation.csv").string(),
                {"step", "time_s", "deformation_step_us", "lag_ms", "newton_iterations", "force_x_N",
                 "force_y_N", "force_z_N", "probed_u_x_m", "probed_u_y_m", "probed_u_z_m", "tangents_made",
                 "staged_tangents_taken"},
                {step, step_time, r.step_us, r.lag_ms, r.iterations, component(r.step_force, 0),
                 component(r.step_force, 1), component(r.step_force, 2), component(r.probed_u, 0),
                 component(r.probed_u, 1), component(r.probed_u, 2), r.tangents, r.staged_tangents});
      double peak = 0;
      for (const Vec3 &f : r.force)
        peak = std::max(peak, std::hypot(f[0], f[1], f[2]));
      const double lockstep = offline ? relative_l2(r.step_force, offline->lockstep) : -1;
      const double implicit = offline ? relative_l2(r.step_force, offline->implicit) : -1;
      const double split    = offline ? relative_l2(offline->lockstep, offline->implicit) : -1;
      std::string  lag_text;
      if (offline && offline->lagged.size() > 1)
        lag_text = write_lag_table(dir / "lag.csv", s, *offline);
      else if (std::error_code ec; fs::exists(dir / "lag.csv", ec) && !fs::remove(dir / "lag.csv", ec))
        throw InputError("--out: cannot remove an earlier run's '" + (dir / "lag.csv").string() + "': " + ec.message());
      const double missed   = static_cast<double>(r.missed) / static_cast<double>(s.n_ticks);
      // Steps published more than a model step late (the force loop then coupled some ticks to
      // a state two steps older than the lockstep split's), and the most of them in a row.
      long late = 0, streak = 0, longest = 0;
      for (const double l : r.lag_ms)
        {
          streak  = l > 1e3 * s.tau ? streak + 1 : 0;
          late   += streak > 0;
          longest = std::max(longest, streak);
        }
      const double late_share = static_cast<double>(late) / static_cast<double>(s.n_steps);
      // Real time kept: the median step within the model's step, and caught up at the end.
      const bool keeps_up = percentile(r.step_us, 0.5) <= 1e6 * s.tau && r.lag_ms.back() <= 1e3 * s.tau;
      const auto   one      = [](const double v) { return std::vector<double>{v}; };
      write_csv((dir / "summary.csv").string(),
                {"rate_hz", "steps", "deformation_steps", "missed", "force_step_p50_us", "force_step_p99_us",
                 "force_step_max_us", "deformation_step_p50_us", "deformation_step_p99_us",
                 "deformation_step_max_us", "lag_p99_ms", "lag_max_ms", "peak_force_N",
                 "lockstep_force_error", "implicit_force_error", "split_force_error", "failed_steps",
                 "cut_steps", "tangent_evaluations", "staged_tangent_evaluations", "tangent_steps", "late_steps",
                 "late_steps_in_a_row"},
                {one(s.rate), one(static_cast<double>(s.n_ticks)), one(static_cast<double>(s.n_steps)),
                 one(static_cast<double>(r.missed)), one(percentile(r.force_us, 0.5)), one(percentile(r.force_us, 0.99)),
                 one(percentile(r.force_us, 1.0)), one(percentile(r.step_us, 0.5)), one(percentile(r.step_us, 0.99)),
                 one(percentile(r.step_us, 1.0)), one(percentile(r.lag_ms, 0.99)), one(percentile(r.lag_ms, 1.0)),
                 one(peak), one(lockstep), one(implicit), one(split), one(static_cast<double>(body.failed_steps())),
                 one(static_cast<double>(body.cut_steps())), one(static_cast<double>(body.tangent_evaluations())),
                 one(static_cast<double>(body.staged_tangent_evaluations())),
                 one(static_cast<double>(s.options.tangent_steps)), one(static_cast<double>(late)),
                 one(static_cast<double>(longest))});
      const auto pct = [](const std::vector<double> &x) {
        return fmt(percentile(x, 0.5)) + " | " + fmt(percentile(x, 0.99)) + " | " + fmt(percentile(x, 0.999)) +
               " | " + fmt(percentile(x, 1.0));
      };
      const ReducedNonlinearModel &m = s.model;
      const std::string md = fill_template(
        read_template("apps/templates/play_reduced.md"),
        {{"stamp", report_stamp()},
         {"model", o.model},
         {"r", std::to_string(m.size)},
         {"lowest", std::to_string(m.lowest_modes)},
         {"residual", std::to_string(m.residual_modes)},
         {"derivatives", std::to_string(m.modal_derivatives)},
         {"elements", std::to_string(m.cubature_elements.size())},
         {"all_elements", std::to_string(m.tetrahedra.size())},
         {"tau_ms", fmt(1e3 * s.tau)},
         {"trajectory", o.trajectory},
         {"duration", fmt(s.duration)},
         {"vertex", std::to_string(s.vertex)},
         {"rest", fmt(s.rest[0], "%.4f") + ", " + fmt(s.rest[1], "%.4f") + ", " + fmt(s.rest[2], "%.4f")},
         {"normal", fmt(s.normal[0], "%.2f") + ", " + fmt(s.normal[1], "%.2f") + ", " + fmt(s.normal[2], "%.2f")},
         {"coupling_stiffness", fmt(o.coupling_stiffness)},
         {"coupling_damping", fmt(o.coupling_damping)},
         {"rate", fmt(s.rate)},
         {"ticks", std::to_string(s.n_ticks)},
         {"steps", std::to_string(s.n_steps)},
         {"force_rt", r.force_rt},
         {"deformation_rt", r.deformation_rt},
         {"force_percentiles", pct(r.force_us)},
         {"late_percentiles", pct(r.late_us)},
         {"step_percentiles", pct(r.step_us)},
         {"lag_percentiles", pct(r.lag_ms)},
         {"iterations_percentiles", pct(r.iterations)},
         {"keeps_up", keeps_up ? "1" : ""},
         {"late_in_a_row", std::to_string(longest)},
         {"final_lag", fmt(r.lag_ms.back())},
         {"step_p50", fmt(percentile(r.step_us, 0.5))},
         {"tau_us", fmt(1e6 * s.tau)},
         {"late_steps", std::to_string(late)},
         {"late_percent", fmt(100 * late_share)},
         {"missed", std::to_string(r.missed)},
         {"missed_percent", fmt(100 * missed)},
         {"failed", std::to_string(body.failed_steps())},
         {"newton_tolerance", fmt(s.options.tolerance)},
         {"cut", std::to_string(body.cut_steps())},
         {"tangents", std::to_string(body.tangent_evaluations())},
         {"staged", std::to_string(body.staged_tangent_evaluations())},
         {"tangent_steps", std::to_string(s.options.tangent_steps)},
         {"staged_mode", s.options.tangent_steps > 0 ? "1" : ""},
         {"checked", offline ? "1" : ""},
         {"lagged", lag_text.empty() ? "" : "1"},
         {"lag_errors", lag_text},
         {"lockstep_error", fmt(lockstep)},
         {"implicit_error", fmt(implicit)},
         {"split_error", fmt(split)},
         {"peak_force", fmt(peak)}});
      write_text_file((dir / "play.md").string(), md);
      out << md;
      return missed > 0.001 ? 3 : 0;
    }
  } // namespace

  int
  run_reduced_play(const PlayOptions &o, std::ostream &out)
  {
    check_output_folder("--out", o.out_dir);
    const fs::path dir(o.out_dir);
    for (const auto &name : {"forces.csv", "deformation.csv", "summary.csv", "play.md", "lag.csv"})
      check_output_file("--out", (dir / name).string(), {o.model, o.trajectory});
    OutputLock   lock((dir / "play").string());
    ReducedSetup s;
    prepare_reduced(s, o, out);
    ReducedRecords       r(s);
    ReducedNonlinearBody body(s.model, s.options);
    if (mlockall(MCL_CURRENT | MCL_FUTURE) != 0 && !o.quiet)
      out << "note: memory not locked (mlockall refused); page faults may add latency\n";
    if (!o.quiet)
      out << "playing " << s.n_ticks << " force ticks at " << fmt(s.rate) << " Hz and " << s.n_steps
          << " deformation steps of " << fmt(1e3 * s.tau) << " ms (" << fmt(s.duration) << " s), coupled to surface vertex "
          << s.vertex << "\n"
          << std::flush;
    // The first step's tangent (at rest, as that step would make it) before the loops start.
    body.prepare_tangent();
    run_reduced_loops(s, r, o, body);
    munlockall();
    const OfflineForces offline = o.check ? offline_forces(s, o.lag_steps) : OfflineForces{};
    return write_reduced_outputs(dir, s, r, o, body, o.check ? &offline : nullptr, out);
  }
} // namespace irdm::play
