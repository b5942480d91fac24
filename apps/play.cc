// irdm play: a force thread and a deformation thread in real time (seed 001 section 4.2).
//
//   force thread        every 1 / rate: sleep to the deadline (absolute, CLOCK_MONOTONIC), one
//                       runtime step (contact solve and force history, all modes), save the
//                       surface state into the triple buffer's back slot, publish.
//   deformation thread  every 1 / display rate: take the newest state if one arrived, full
//                       surface update (M modes and the static correction).
//
// The device is a point probe on one model vertex. It prescribes that vertex's displacement
// (device tip minus the vertex's rest position) while the tip is behind the rest surface along
// the vertex normal, and lets go otherwise: the press scenes' bilateral probe that lets go.
// One model step per force tick: at a rate other than 1 / time_step the trajectory plays at
// rate * time_step times real speed (said in play.md). Nothing in either loop allocates or
// locks; every buffer is sized before the threads start.
#include "play.h"
#include "play_realtime.h"

#include <irdm/modal_model.h>
#include <irdm/model.h>
#include <irdm/point_interaction.h>
#include <irdm/surface_exchange.h>
#include <irdm_common/format.h>
#include <irdm_common/report_stamp.h>
#include <irdm_common/report_template.h>
#include <irdm_common/csv.h>
#include <irdm_common/error.h>
#include <irdm_common/files.h>
#include <irdm_common/h5.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <numeric>
#include <sstream>
#include <thread>
#include <vector>

#include <pthread.h>
#include <sched.h>
#include <sys/mman.h>
#include <time.h>

namespace irdm::play
{
  namespace
  {
    namespace fs = std::filesystem;

    // The surface as an ASCII VTU: deformed points, triangles, and the displacement (m).
    std::string
    vtu(const ModelFrame &m, const double *u)
    {
      const size_t       nv = m.output_coordinates.size(), nt = m.triangles.size();
      std::ostringstream s;
      s.precision(9);
      s << "<?xml version=\"1.0\"?>\n<VTKFile type=\"UnstructuredGrid\" version=\"0.1\">\n"
        << "<UnstructuredGrid><Piece NumberOfPoints=\"" << nv << "\" NumberOfCells=\"" << nt
        << "\">\n<Points><DataArray type=\"Float64\" NumberOfComponents=\"3\" format=\"ascii\">\n";
      for (size_t v = 0; v < nv; ++v)
        s << m.output_coordinates[v][0] + u[3 * v] << ' ' << m.output_coordinates[v][1] + u[3 * v + 1]
          << ' ' << m.output_coordinates[v][2] + u[3 * v + 2] << '\n';
      s << "</DataArray></Points>\n<Cells><DataArray type=\"Int64\" Name=\"connectivity\" "
           "format=\"ascii\">\n";
      for (const auto &t : m.triangles)
        s << t[0] << ' ' << t[1] << ' ' << t[2] << '\n';
      s << "</DataArray><DataArray type=\"Int64\" Name=\"offsets\" format=\"ascii\">\n";
      for (size_t t = 0; t < nt; ++t)
        s << 3 * (t + 1) << '\n';
      s << "</DataArray><DataArray type=\"UInt8\" Name=\"types\" format=\"ascii\">\n";
      for (size_t t = 0; t < nt; ++t)
        s << "5\n";
      s << "</DataArray></Cells>\n<PointData Vectors=\"displacement_m\"><DataArray "
           "type=\"Float64\" Name=\"displacement_m\" NumberOfComponents=\"3\" format=\"ascii\">\n";
      for (size_t v = 0; v < nv; ++v)
        s << u[3 * v] << ' ' << u[3 * v + 1] << ' ' << u[3 * v + 2] << '\n';
      s << "</DataArray></PointData>\n</Piece></UnstructuredGrid>\n</VTKFile>\n";
      return s.str();
    }


    /// What the run plays: the model and its modal realization, the probed vertex, and every
    /// step's probe, made before the loops.
    struct Setup
    {
      Trajectory           trajectory;
      ImpulseResponseModel model;
      ModalModelOptions    mo;
      ModalModel           modal;
      double               tau = 0, rate = 0, speed = 0, duration = 0;
      unsigned             vertex = 0;
      Vec3                 normal{}, rest{};
      long                 n_steps = 0;
      std::vector<ProbeTarget> probes;
      std::vector<double>      present;
      // The device's own motion; with a virtual coupling each step's probe prescribes the
      // coupling's target behind its compliance instead (couple()).
      std::vector<Vec3>  device;
      contact::Coupling  coupling{0, 0};

      /// Step n's probe: the coupling's target from the device now and one step before and the
      /// vertex one step before (arithmetic only, done in the force loop).
      const ProbeTarget *
      couple(const long n, const Vec3 &u_before)
      {
        if (!coupling.rigid())
          probes[n].displacement =
            coupling.target(device[n], n > 0 ? device[n - 1] : Vec3{0, 0, 0}, u_before, tau);
        return &probes[n];
      }
    };

    /// The probed vertex: given, or the input vertex nearest the trajectory's first sample.
    unsigned
    probed_vertex(const PlayOptions &o, const ModelFrame &model, const Trajectory &trajectory)
    {
      if (o.vertex >= 0)
        {
          if (o.vertex >= static_cast<long>(model.output_coordinates.size()) ||
              model.output_input_index[o.vertex] < 0)
            throw InputError("--vertex " + std::to_string(o.vertex) +
                             " is not a model input vertex (a probe can touch only inputs)");
          return static_cast<unsigned>(o.vertex);
        }
      unsigned vertex = 0;
      double   best   = 1e300;
      for (unsigned v = 0; v < model.output_coordinates.size(); ++v)
        if (model.output_input_index[v] >= 0)
          {
            double d = 0;
            for (int k = 0; k < 3; ++k)
              d += std::pow(model.output_coordinates[v][k] - trajectory.tip[0][k], 2);
            if (d < best)
              best = d, vertex = v;
          }
      return vertex;
    }

    /// Every step's probe. It touches where the device crossed the rest surface: from then on
    /// it prescribes the vertex's displacement as the device's motion since that crossing
    /// (continuous at first touch, drags along while pressed), and lets go when the device is
    /// back outside.
    void
    make_probes(Setup &s, const PlayOptions &o)
    {
      s.probes.resize(s.n_steps);
      s.present.resize(s.n_steps);
      Vec3 touch{0, 0, 0};
      for (long n = 0; n < s.n_steps; ++n)
        {
          const Vec3   tip   = tip_at(s.trajectory, s.trajectory.time.front() + (n + 1) * s.tau);
          ProbeTarget &p     = s.probes[n];
          double       depth = 0;
          for (int d = 0; d < 3; ++d)
            depth -= (tip[d] - s.rest[d]) * s.normal[d];
          p.n_patch           = 1;
          p.patch_vertices[0] = s.vertex;
          p.patch_weights[0]  = 1;
          p.present           = depth > 0;
          if (p.present && (n == 0 || !s.probes[n - 1].present))
            for (int d = 0; d < 3; ++d) // where the tip crossed the tangent plane
              touch[d] = tip[d] + depth * s.normal[d];
          for (int d = 0; d < 3; ++d)
            {
              p.direction[d]    = -s.normal[d];
              p.displacement[d] = p.present ? tip[d] - touch[d] : 0;
            }
          s.present[n] = p.present;
        }
      s.coupling = contact::Coupling{o.coupling_stiffness, o.coupling_damping};
      s.device.resize(s.n_steps);
      for (long n = 0; n < s.n_steps; ++n)
        {
          s.device[n] = s.probes[n].displacement;
          if (!s.coupling.rigid())
            {
              s.probes[n].unilateral = true;
              s.probes[n].compliance = s.coupling.compliance(s.tau);
            }
        }
    }

    /// Inputs, all checked before any work: the options, the trajectory, the model.
    void
    prepare(Setup &s, const PlayOptions &o, std::ostream &out)
    {
      s.trajectory = read_trajectory(o.trajectory);
      if (!o.quiet)
        out << "loading " << o.model << "\n" << std::flush;
      s.model = load_model(o.model, {}, ModelParts::modal_realization);
      s.mo.surface_modes = std::min<unsigned>(o.surface_modes, std::max(1u, s.model.modes.n_modes));
      s.mo.force_modes   = o.force_modes == 0 ? 0 : std::max(o.force_modes, s.mo.surface_modes);
      s.modal            = make_modal_model(s.model, s.mo);
      s.tau              = s.model.time_step;
      s.rate             = o.rate_hz > 0 ? o.rate_hz : 1 / s.tau;
      if (s.rate > 100000)
        throw InputError("--rate-hz must be at most 100000");
      s.speed  = s.rate * s.tau; // trajectory time per real time
      s.vertex = probed_vertex(o, s.model, s.trajectory);
      s.normal = outward_normal(s.model.output_coordinates, s.model.triangles, s.vertex);
      s.rest   = s.model.output_coordinates[s.vertex];
      s.duration = s.trajectory.time.back() - s.trajectory.time.front();
      s.n_steps  = static_cast<long>(std::floor(s.duration / s.tau + 1e-9));
      if (s.n_steps < 1)
        throw InputError("--trajectory: shorter than one model step (" + fmt(s.tau) + " s)");
      make_probes(s, o);
    }

    /// What the loops record, every buffer sized before the threads start, and the timing they
    /// keep.
    struct Records
    {
      // Per force step.
      std::vector<double>       force_x, force_y, force_z, step_us, late_us;
      std::vector<std::int64_t> wake_ns;
      std::vector<double>       baseline_late_us;
      // Per display tick: surface updates, warm-ups, and the frames kept.
      long                   display_ticks = 0, frame_stride = 1;
      std::vector<double>    update_us, update_step, warm_us, frame_u;
      std::vector<long long> frame_step;
      long                   n_updates = 0, n_warms = 0, n_frames = 0, display_tick_count = 0;
      // What each thread's spins saw of its CPU (room for 64 gaps per frame, 4 per tick).
      Interruptions display_seen{0}, force_seen{0}, baseline_seen{0};
      std::vector<double> jitter_us, abs_jitter; // each tick's wake-to-wake time against the period
      long                missed = 0;
      std::string         force_rt, display_rt;
      int                 n_cpus = 1;
      std::int64_t        period_ns = 0, display_ns = 0, warm_ns = 0, spin_ns = 0;
      double              spin_us = 0;

      Records(const Setup &s, const PlayOptions &o)
        : force_x(s.n_steps), force_y(s.n_steps), force_z(s.n_steps), step_us(s.n_steps),
          late_us(s.n_steps), wake_ns(s.n_steps), baseline_late_us(o.baseline ? s.n_steps : 0),
          display_ticks(static_cast<long>(std::ceil(s.n_steps / s.rate * o.display_hz)) + 2),
          frame_stride(std::max<long>(1, (display_ticks + o.max_frames - 1) / std::max(1u, o.max_frames))),
          update_us(display_ticks, 0.0), update_step(display_ticks, 0.0), warm_us(display_ticks, 0.0),
          frame_u(static_cast<size_t>((display_ticks / frame_stride + 1)) * s.model.n_outputs, 0.0),
          frame_step(display_ticks / frame_stride + 1, 0),
          display_seen(static_cast<size_t>(display_ticks) * 64),
          force_seen(static_cast<size_t>(s.n_steps) * 4), baseline_seen(static_cast<size_t>(s.n_steps) * 4),
          n_cpus(static_cast<int>(std::thread::hardware_concurrency())),
          period_ns(static_cast<std::int64_t>(std::llround(1e9 / s.rate))),
          display_ns(static_cast<std::int64_t>(std::llround(1e9 / o.display_hz))),
          warm_ns(std::min(display_ns / 2, static_cast<std::int64_t>(std::llround(1e3 * o.warm_us)))),
          spin_ns(0), spin_us(o.spin_us < 0 ? 0.9e6 / s.rate : std::min(o.spin_us, 1e6 / s.rate))
      {
        spin_ns = static_cast<std::int64_t>(std::llround(1e3 * spin_us));
      }
    };

    // Pieces of the shapes per warm-up pass when they are kept warm: about 10 kB each for the
    // cat's, read in under a microsecond, so that the gaps between clock reads stay those of
    // the spin.
    constexpr size_t warm_parts = 64;

    /// The two loops in real time (and, first, the baseline: the same force loop doing no work).
    class RealTimeRun
    {
    public:
      RealTimeRun(Setup &s, Records &r, const PlayOptions &o)
        : s(s), r(r), o(o), runtime(s.modal), exchange(make_surface_state(s.modal)),
          surface(s.model.n_outputs)
      {}

      void
      run();

    private:
      std::int64_t wait_for_start();
      void         baseline();
      void         force_loop();
      void         deformation_loop();
      void         warm_up_to(std::int64_t frame);

      Setup                          &s;
      Records                        &r;
      const PlayOptions              &o;
      ModalInteraction                runtime;
      TripleBuffer<ModalSurfaceState> exchange;
      std::vector<double>             surface;
      std::atomic<bool>               force_done{false};
      // The clock starts once both threads run where they should (creating a thread under
      // mlockall faults in its whole stack, tens of ms on this VM), and 10 ms later.
      std::atomic<int>          threads_ready{0};
      std::atomic<std::int64_t> start_at{0};
    };

    std::int64_t
    RealTimeRun::wait_for_start()
    {
      if (threads_ready.fetch_add(1) + 1 == 2)
        start_at.store(now_ns() + 10000000, std::memory_order_release);
      std::int64_t t;
      // Sleeps, not yields: a FIFO thread yielding on main's CPU would starve it.
      while ((t = start_at.load(std::memory_order_acquire)) == 0)
        std::this_thread::sleep_for(std::chrono::microseconds(100));
      return t;
    }

    /// The machine's own stalls, measured beside the run: the same force loop (CPU, priority,
    /// sleep and spin) doing no work, just before and as long. A tick it wakes more than a
    /// period late would be missed by any step; what the runtime misses beyond these is its own.
    void
    RealTimeRun::baseline()
    {
      std::thread idle([&] {
        make_real_time(o.pin && r.n_cpus > 1 ? r.n_cpus - 1 : -1, 80);
        const std::int64_t start = now_ns() + 10000000;
        for (long n = 0; n < s.n_steps; ++n)
          {
            const std::int64_t deadline = start + n * r.period_ns;
            r.baseline_late_us[n] =
              1e-3 * static_cast<double>(wait_for_tick(deadline, r.spin_ns, [] {}, r.baseline_seen) - deadline);
          }
      });
      idle.join();
    }

    void
    RealTimeRun::force_loop()
    {
      r.force_rt               = make_real_time(o.pin && r.n_cpus > 1 ? r.n_cpus - 1 : -1, 80);
      const std::int64_t start = wait_for_start();
      for (long n = 0; n < s.n_steps; ++n)
        {
          const std::int64_t deadline = start + n * r.period_ns;
          const std::int64_t wake     = wait_for_tick(deadline, r.spin_ns, [&] {
            if (o.warm_step)
              runtime.warm_step();
          }, r.force_seen, o.warm_step && o.keep_warm);
          runtime.step(s.couple(n, runtime.probe_displacement(0)), 1);
          runtime.save_surface_state(exchange.back());
          exchange.publish();
          const std::int64_t done = now_ns();
          const auto        &f    = runtime.force(0);
          r.force_x[n] = f[0], r.force_y[n] = f[1], r.force_z[n] = f[2];
          r.wake_ns[n] = wake;
          r.step_us[n] = 1e-3 * static_cast<double>(done - wake);
          r.late_us[n] = 1e-3 * static_cast<double>(wake - deadline);
          if (done > deadline + r.period_ns)
            ++r.missed;
        }
      force_done.store(true, std::memory_order_release);
    }

    /// The deformation thread's wait for a frame, warming the surface shapes in its cache.
    void
    RealTimeRun::warm_up_to(const std::int64_t frame)
    {
      if (r.warm_ns > 0 && o.keep_warm)
        {
          // The shapes a piece at a time, round and round until the frame; the first whole
          // pass of each frame is the one timed.
          size_t       part = 0;
          std::int64_t from = 0;
          wait_for_tick(frame, r.warm_ns, [&] {
            if (from == 0)
              from = now_ns();
            warm_surface(s.modal, part, warm_parts);
            if (++part == warm_parts)
              {
                if (from > 0 && r.n_warms < static_cast<long>(r.warm_us.size()))
                  r.warm_us[r.n_warms++] = 1e-3 * static_cast<double>(now_ns() - from);
                from = -1, part = 0;
              }
          }, r.display_seen, true);
        }
      else if (r.warm_ns > 0)
        wait_for_tick(frame, r.warm_ns, [&] {
          const std::int64_t t0 = now_ns();
          warm_surface(s.modal);
          if (r.n_warms < static_cast<long>(r.warm_us.size())) // one per frame; never past it
            r.warm_us[r.n_warms++] = 1e-3 * static_cast<double>(now_ns() - t0);
        }, r.display_seen);
      else
        sleep_until_ns(frame);
    }

    void
    RealTimeRun::deformation_loop()
    {
      r.display_rt             = make_real_time(o.pin && r.n_cpus > 1 ? 0 : -1, 70);
      const std::int64_t start = wait_for_start();
      for (long tick = 0; tick < r.display_ticks; ++tick)
        {
          // The first frame too: the clock starts 10 ms after both threads run, time enough.
          warm_up_to(start + tick * r.display_ns);
          const bool finished = force_done.load(std::memory_order_acquire);
          if (exchange.update())
            {
              const std::int64_t t0 = now_ns();
              surface_displacement(s.modal, exchange.front(), surface.data());
              r.update_us[r.n_updates]     = 1e-3 * static_cast<double>(now_ns() - t0);
              r.update_step[r.n_updates++] = static_cast<double>(exchange.front().steps);
              if (r.display_tick_count++ % r.frame_stride == 0)
                {
                  std::copy(surface.begin(), surface.end(),
                            &r.frame_u[static_cast<size_t>(r.n_frames) * s.model.n_outputs]);
                  r.frame_step[r.n_frames++] = exchange.front().steps;
                }
            }
          else if (finished)
            break;
        }
    }

    void
    RealTimeRun::run()
    {
      if (o.baseline)
        baseline();
      std::thread force([&] { force_loop(); });
      std::thread deformation([&] { deformation_loop(); });
      force.join();
      deformation.join();
      for (long n = 1; n < s.n_steps; ++n)
        r.jitter_us.push_back(1e-3 * static_cast<double>(r.wake_ns[n] - r.wake_ns[n - 1] - r.period_ns));
      r.abs_jitter.resize(r.jitter_us.size());
      std::transform(r.jitter_us.begin(), r.jitter_us.end(), r.abs_jitter.begin(),
                     [](double x) { return std::abs(x); });
      r.update_us.resize(r.n_updates);
      r.update_step.resize(r.n_updates);
      r.warm_us.resize(r.n_warms);
      for (Interruptions *seen : {&r.display_seen, &r.force_seen, &r.baseline_seen})
        seen->gap_us.resize(seen->count);
    }

    /// The probe's forces over the trajectory, replayed offline (no clock) on a modal model.
    std::vector<Vec3>
    offline_forces(Setup &s, const ModalModel &model)
    {
      ModalInteraction  runtime(model);
      std::vector<Vec3> f(static_cast<size_t>(s.n_steps));
      for (long n = 0; n < s.n_steps; ++n)
        {
          runtime.step(s.couple(n, runtime.probe_displacement(0)), 1);
          f[n] = runtime.force(0);
        }
      return f;
    }

    /// The every-mode model (the modal realization with all modes reproduces H and the FEM,
    /// tests/test_irdm.cc).
    ModalModel
    every_mode(const Setup &s)
    {
      ModalModelOptions all = s.mo;
      all.force_modes       = 0;
      return make_modal_model(s.model, all);
    }

    /// --force-tolerance: the fewest force-loop modes of the grid whose offline forces over the
    /// trajectory are within the tolerance of every mode's (the rest quasi-static, as in the
    /// run); every mode when none is. Sets s.mo.force_modes and s.modal.
    void
    size_force_modes(Setup &s, const double tolerance, std::ostream &out, const bool quiet)
    {
      // --force-tolerance excludes --force-modes: s.modal has every mode in its force loop.
      const auto exact = offline_forces(s, s.mo.force_modes == 0 ? s.modal : every_mode(s));
      for (const unsigned k : {25u, 50u, 100u, 200u, 400u, 800u, 1600u, 3200u, 6400u})
        {
          if (k >= s.model.modes.n_modes)
            break;
          ModalModelOptions o = s.mo;
          o.force_modes       = std::max(k, s.mo.surface_modes);
          ModalModel   m      = make_modal_model(s.model, o);
          const double e      = relative_l2(offline_forces(s, m), exact);
          if (!quiet)
            out << "force-loop modes " << o.force_modes << ": force " << fmt(e)
                << " (relative L2 over the trajectory, against every mode)\n";
          if (e <= tolerance)
            {
              s.mo    = o;
              s.modal = std::move(m);
              return;
            }
        }
      if (!quiet)
        out << "force-loop modes: every mode (no fewer of the grid within " << fmt(tolerance) << ")\n";
      s.mo.force_modes = 0;
      s.modal          = make_modal_model(s.model, s.mo);
    }

    /// The same probes offline with every mode in the force loop; relative L2 of the real-time
    /// forces against it.
    double
    offline_force_error(Setup &s, const Records &r)
    {
      const auto exact = offline_forces(s, s.mo.force_modes == 0 ? s.modal : every_mode(s));
      std::vector<Vec3> real_time(exact.size());
      for (size_t n = 0; n < exact.size(); ++n)
        real_time[n] = {r.force_x[n], r.force_y[n], r.force_z[n]};
      return relative_l2(real_time, exact);
    }
  } // namespace

  namespace
  {
    /// forces.csv, surface_updates.csv, histogram.csv and the VTU frames.
    void
    write_records(const fs::path &dir, const Setup &s, const Records &r)
    {
      const long          N = s.n_steps;
      std::vector<double> step_index(N), time_s(N), dx(N), dy(N), dz(N);
      for (long n = 0; n < N; ++n)
        {
          step_index[n] = static_cast<double>(n);
          time_s[n]     = (n + 1) * s.tau;
          dx[n]         = s.rest[0] + s.device[n][0];
          dy[n]         = s.rest[1] + s.device[n][1];
          dz[n]         = s.rest[2] + s.device[n][2];
        }
      write_csv((dir / "forces.csv").string(),
                {"step", "time_s", "device_x_m", "device_y_m", "device_z_m", "present", "force_x_N",
                 "force_y_N", "force_z_N", "force_step_us", "wake_late_us"},
                {step_index, time_s, dx, dy, dz, s.present, r.force_x, r.force_y, r.force_z,
                 r.step_us, r.late_us});
      // Every surface update's latency, for percentiles pooled over repeated runs.
      std::vector<double> index(r.update_us.size());
      std::iota(index.begin(), index.end(), 0.0);
      write_csv((dir / "surface_updates.csv").string(), {"update", "steps", "surface_update_us"},
                {index, r.update_step, r.update_us});
      std::vector<double> lo(Histogram::bins), hi(Histogram::bins);
      for (int b = 0; b < Histogram::bins; ++b)
        lo[b] = Histogram::low(b), hi[b] = Histogram::low(b + 1);
      write_csv((dir / "histogram.csv").string(),
                {"bin_low_us", "bin_high_us", "force_step", "period_jitter_abs", "surface_update"},
                {lo, hi, Histogram::count(r.step_us), Histogram::count(r.abs_jitter),
                 Histogram::count(r.update_us)});
      fs::create_directories(dir / "surface");
      std::ostringstream pvd;
      pvd << "<?xml version=\"1.0\"?>\n<VTKFile type=\"Collection\" version=\"0.1\">\n<Collection>\n";
      for (long f = 0; f < r.n_frames; ++f)
        {
          char name[64];
          std::snprintf(name, sizeof name, "surface_%04ld.vtu", f);
          write_text_file((dir / "surface" / name).string(),
                          vtu(s.model, &r.frame_u[static_cast<size_t>(f) * s.model.n_outputs]));
          pvd << "<DataSet timestep=\"" << r.frame_step[f] * s.tau << "\" file=\"" << name << "\"/>\n";
        }
      pvd << "</Collection>\n</VTKFile>\n";
      write_text_file((dir / "surface" / "surface.pvd").string(), pvd.str());
    }

    /// The run's figures, as summary.csv and play.md give them.
    struct Summary
    {
      double peak_force = 0, missed_fraction = 0, achieved_display = 0, count_present = 0;
      long   missed_overrun = 0; // deadlines missed because the step took longer than a period
      Stalls stalls, baseline;   // consecutive late wake-ups: one stall of the machine each
      double force_error = -1;   // against the exact model offline; -1: not run
    };

    Summary
    summarize(const Setup &s, const Records &r, const double force_error)
    {
      Summary m;
      m.force_error   = force_error;
      m.count_present = static_cast<double>(std::count(s.present.begin(), s.present.end(), 1.0));
      for (long n = 0; n < s.n_steps; ++n)
        m.peak_force = std::max(m.peak_force, std::sqrt(r.force_x[n] * r.force_x[n] + r.force_y[n] * r.force_y[n] +
                                                        r.force_z[n] * r.force_z[n]));
      m.missed_fraction = static_cast<double>(r.missed) / s.n_steps;
      // Why each deadline was missed: the step itself took longer than a period, or the
      // thread was not running at its tick (woken late).
      const double period_us = 1e-3 * static_cast<double>(r.period_ns);
      for (long n = 0; n < s.n_steps; ++n)
        m.missed_overrun += r.step_us[n] > period_us;
      m.stalls   = stalls_of(r.late_us, period_us);
      m.baseline = stalls_of(r.baseline_late_us, period_us);
      m.achieved_display = r.n_updates > 0 ? r.n_updates / (static_cast<double>(s.n_steps) / s.rate) : 0;
      return m;
    }

    /// summary.csv: one row for scripts that gather many runs (scripts/play_study.sh).
    void
    write_summary(const fs::path &dir, const Setup &s, const Records &r, const PlayOptions &o,
                  const Summary &m)
    {
      const auto one = [](const double v) { return std::vector<double>{v}; };
      write_csv((dir / "summary.csv").string(),
                {"rate_hz", "spin_us", "steps", "missed", "missed_step_overrun", "missed_woken_late",
                 "stalls", "longest_stall_ms", "baseline_missed", "baseline_stalls",
                 "baseline_longest_stall_ms", "force_step_p50_us", "force_step_p99_us",
                 "force_step_p999_us", "force_step_max_us", "wake_late_p50_us", "wake_late_p99_us",
                 "period_jitter_p99_us", "surface_update_p50_us", "surface_update_p99_us",
                 "surface_update_max_us", "surface_updates", "peak_force_N", "force_error",
                 "warm_us", "surface_warm_p50_us", "surface_warm_p99_us", "warm_step",
                 "display_interruptions_per_s", "display_interruption_p50_us",
                 "display_interruption_max_us", "force_interruptions_per_s",
                 "force_interruption_p50_us", "force_interruption_max_us", "keep_warm",
                 "force_modes"},
                {one(s.rate), one(r.spin_us), one(static_cast<double>(s.n_steps)),
                 one(static_cast<double>(r.missed)), one(static_cast<double>(m.missed_overrun)),
                 one(static_cast<double>(r.missed - m.missed_overrun)),
                 one(static_cast<double>(m.stalls.count)), one(1e-3 * m.stalls.longest_us),
                 one(o.baseline ? static_cast<double>(m.baseline.late_ticks) : -1),
                 one(o.baseline ? static_cast<double>(m.baseline.count) : -1),
                 one(o.baseline ? 1e-3 * m.baseline.longest_us : -1), one(percentile(r.step_us, 0.5)),
                 one(percentile(r.step_us, 0.99)), one(percentile(r.step_us, 0.999)),
                 one(percentile(r.step_us, 1.0)), one(percentile(r.late_us, 0.5)),
                 one(percentile(r.late_us, 0.99)), one(percentile(r.abs_jitter, 0.99)),
                 one(percentile(r.update_us, 0.5)), one(percentile(r.update_us, 0.99)),
                 one(percentile(r.update_us, 1.0)), one(static_cast<double>(r.n_updates)),
                 one(m.peak_force), one(m.force_error), one(1e-3 * static_cast<double>(r.warm_ns)),
                 one(percentile(r.warm_us, 0.5)), one(percentile(r.warm_us, 0.99)),
                 one(o.warm_step ? 1 : 0), one(r.display_seen.per_second()),
                 one(percentile(r.display_seen.gap_us, 0.5)), one(percentile(r.display_seen.gap_us, 1.0)),
                 one(r.force_seen.per_second()), one(percentile(r.force_seen.gap_us, 0.5)),
                 one(percentile(r.force_seen.gap_us, 1.0)), one(o.keep_warm ? 1 : 0),
                 one(static_cast<double>(s.modal.force_modes))});
    }

    /// "p50 | p99 | p99.9 | max" of a latency table's row.
    std::string
    percentiles(const std::vector<double> &us)
    {
      return fmt(percentile(us, 0.5)) + " | " + fmt(percentile(us, 0.99)) + " | " +
             fmt(percentile(us, 0.999)) + " | " + fmt(percentile(us, 1.0));
    }

    /// How often a thread's spins were interrupted, and for how long.
    std::string
    interruptions_text(const Interruptions &seen)
    {
      return std::to_string(seen.count) + " gaps in " + fmt(1e-9 * static_cast<double>(seen.spun_ns)) +
             " s of spinning (" + fmt(seen.per_second()) + " per s; p50 " +
             fmt(percentile(seen.gap_us, 0.5)) + " us, p99 " + fmt(percentile(seen.gap_us, 0.99)) +
             " us, longest " + fmt(percentile(seen.gap_us, 1.0)) + " us)";
    }

    /// play.md, from apps/templates/play.md.
    std::string
    play_report(const Setup &s, const Records &r, const PlayOptions &o, const Summary &m)
    {
      const auto &modal = s.modal;
      return fill_template(
        read_template("apps/templates/play.md"),
        {{"stamp", report_stamp()},
         {"model", o.model},
         {"input_vertices", std::to_string(s.model.n_inputs / 3)},
         {"surface_vertices", std::to_string(s.model.n_outputs / 3)},
         {"force_modes", std::to_string(modal.force_modes)},
         {"n_modes", std::to_string(modal.n_modes)},
         {"all_modes", modal.force_modes == modal.n_modes ? "1" : ""},
         {"surface_modes", std::to_string(modal.surface_modes)},
         {"tau_ms", fmt(s.tau * 1e3)},
         {"trajectory", o.trajectory},
         {"duration", fmt(s.duration)},
         {"vertex", std::to_string(s.vertex)},
         {"rest", fmt(s.rest[0], "%.4f") + ", " + fmt(s.rest[1], "%.4f") + ", " + fmt(s.rest[2], "%.4f")},
         {"normal", fmt(s.normal[0], "%.2f") + ", " + fmt(s.normal[1], "%.2f") + ", " + fmt(s.normal[2], "%.2f")},
         {"coupled", s.coupling.rigid() ? "" : "1"},
         {"coupling_stiffness", fmt(s.coupling.stiffness)},
         {"coupling_damping", fmt(s.coupling.damping)},
         {"present_percent", fmt(100 * m.count_present / s.n_steps)},
         {"rate", fmt(s.rate)},
         {"steps", std::to_string(s.n_steps)},
         {"real_time", std::abs(s.speed - 1) < 1e-9 ? "1" : ""},
         {"speed", fmt(s.speed)},
         {"force_rt", r.force_rt},
         {"spin", r.spin_ns > 0 ? "1" : ""},
         {"spin_us", fmt(r.spin_us)},
         {"warm_step", o.warm_step ? "1" : ""},
         {"keep_warm", o.keep_warm ? "1" : ""},
         {"display_hz", fmt(o.display_hz)},
         {"display_rt", r.display_rt},
         {"updates", std::to_string(r.n_updates)},
         {"achieved_display", fmt(m.achieved_display)},
         {"cpus", std::to_string(r.n_cpus)},
         {"step_percentiles", percentiles(r.step_us)},
         {"jitter_percentiles", percentiles(r.abs_jitter)},
         {"late_percentiles", percentiles(r.late_us)},
         {"update_percentiles", percentiles(r.update_us)},
         {"warm_percentiles", percentiles(r.warm_us)},
         {"warm", r.warm_ns > 0 ? "1" : ""},
         {"warm_lead_us", fmt(1e-3 * static_cast<double>(r.warm_ns))},
         {"warm_parts", std::to_string(warm_parts)},
         {"force_interruptions", interruptions_text(r.force_seen)},
         {"display_interruptions", interruptions_text(r.display_seen)},
         {"baseline", o.baseline ? "1" : ""},
         {"baseline_interruptions", interruptions_text(r.baseline_seen)},
         {"step_interrupted", fmt(100 * r.force_seen.per_second() * 1e-6 * percentile(r.step_us, 0.5))},
         {"update_interrupted", fmt(100 * r.display_seen.per_second() * 1e-6 * percentile(r.update_us, 0.5))},
         {"missed", std::to_string(r.missed)},
         {"missed_percent", fmt(100 * m.missed_fraction)},
         {"missed_overrun", std::to_string(m.missed_overrun)},
         {"missed_late", std::to_string(r.missed - m.missed_overrun)},
         {"stalls", std::to_string(m.stalls.count)},
         {"longest_stall_ms", m.stalls.count > 0 ? fmt(1e-3 * m.stalls.longest_us) : ""},
         {"baseline_late", std::to_string(m.baseline.late_ticks)},
         {"baseline_late_percent", fmt(100.0 * m.baseline.late_ticks / s.n_steps)},
         {"baseline_stalls", std::to_string(m.baseline.count)},
         {"baseline_longest_ms", m.baseline.count > 0 ? fmt(1e-3 * m.baseline.longest_us) : ""},
         {"checked", m.force_error >= 0 ? "1" : ""},
         {"force_error", fmt(m.force_error)},
         {"peak_force", fmt(m.peak_force)},
         {"frames", std::to_string(r.n_frames)}});
    }
  } // namespace

  int
  run_play(const PlayOptions &o, std::ostream &out)
  {
    // Inputs first, all checked before any work.
    if (!(o.display_hz > 0 && o.display_hz <= 10000))
      throw InputError("--display-hz must be in (0, 10000]");
    {
      const h5::Reader file(o.model); // InputError for a missing or non-HDF5 file
      if (file.has_attribute("/", "format") && file.string_attribute("/", "format") == "irdm-reduced-model")
        {
          if (o.force_tolerance > 0 || o.force_modes > 0)
            throw InputError("--force-modes and --force-tolerance are for a linear model's modes; "
                             "a reduced nonlinear model's force loop has no modes to choose");
          if (!o.lag_steps.empty() && !o.check)
            throw InputError("--lag-steps reruns the offline check: not with --no-check");
          return run_reduced_play(o, out);
        }
    }
    if (!o.lag_steps.empty())
      throw InputError("--lag-steps is for a reduced nonlinear model's two loops");
    check_output_folder("--out", o.out_dir);
    const fs::path dir(o.out_dir);
    for (const auto &name :
         {"forces.csv", "surface_updates.csv", "histogram.csv", "summary.csv", "play.md"})
      check_output_file("--out", (dir / name).string(), {o.model, o.trajectory});
    OutputLock lock((dir / "play").string());
    Setup      s;
    prepare(s, o, out);
    if (o.force_tolerance > 0)
      size_force_modes(s, o.force_tolerance, out, o.quiet);
    Records r(s, o);
    if (mlockall(MCL_CURRENT | MCL_FUTURE) != 0 && !o.quiet)
      out << "note: memory not locked (mlockall refused); page faults may add latency\n";
    {
      RealTimeRun run(s, r, o);
      if (!o.quiet)
        out << "playing " << s.n_steps << " steps at " << fmt(s.rate) << " Hz ("
            << fmt(s.n_steps / s.rate) << " s), display at " << fmt(o.display_hz)
            << " Hz, probe on vertex " << s.vertex << "\n"
            << std::flush;
      run.run();
    }
    munlockall();
    const Summary m = summarize(s, r, o.check ? offline_force_error(s, r) : -1);
    write_records(dir, s, r);
    write_summary(dir, s, r, o, m);
    const std::string md = play_report(s, r, o, m);
    write_text_file((dir / "play.md").string(), md);
    out << md;
    return m.missed_fraction > 0.001 ? 3 : 0;
  }
} // namespace irdm::play
