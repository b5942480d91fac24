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

#include <irdm/modal_model.h>
#include <irdm/model.h>
#include <irdm/point_interaction.h>
#include <irdm/surface_exchange.h>
#include <irdm_common/format.h>
#include <irdm_common/report_stamp.h>
#include <irdm_common/csv.h>
#include <irdm_common/error.h>
#include <irdm_common/files.h>

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
    using Vec3   = std::array<double, 3>;

    std::int64_t
    now_ns()
    {
      timespec t{};
      clock_gettime(CLOCK_MONOTONIC, &t);
      return static_cast<std::int64_t>(t.tv_sec) * 1000000000 + t.tv_nsec;
    }

    void
    sleep_until_ns(const std::int64_t deadline)
    {
      timespec t{};
      t.tv_sec  = deadline / 1000000000;
      t.tv_nsec = deadline % 1000000000;
      while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &t, nullptr) == EINTR)
        {
        }
    }

    // What a thread's spins saw of its CPU: a gap over 2 us between two clock reads is time
    // the thread did not run (an interrupt, or the host running something else). Their rate
    // and lengths are what the machine does to a step or an update of a given length. Sized
    // before the loop; gaps beyond its room are counted in time but not kept.
    struct Interruptions
    {
      std::vector<double> gap_us;
      size_t              count   = 0;
      std::int64_t        spun_ns = 0;

      explicit Interruptions(const size_t room)
        : gap_us(room)
      {}
      // Spins to the absolute time `until` (ns), recording the gaps. Returns the time it left
      // (the time it came, if that was already past `until`).
      std::int64_t
      spin_to(const std::int64_t until)
      {
        const std::int64_t from = now_ns();
        std::int64_t       last = from;
        while (last < until)
          {
            const std::int64_t t = now_ns();
            seen(t - last);
            last = t;
          }
        spun_ns += last - from;
        return last;
      }
      // One warm-up pass of `pass_ns` inside a spin, against the fastest so far.
      void
      passed(const std::int64_t pass_ns, const std::int64_t fastest_ns)
      {
        seen(pass_ns - fastest_ns);
        spun_ns += pass_ns;
      }
      // Time the thread may not have run (ns): a gap if over 2 us, kept while there is room.
      void
      seen(const std::int64_t ns)
      {
        if (ns > 2000 && count < gap_us.size())
          gap_us[count++] = 1e-3 * static_cast<double>(ns);
      }
      double
      per_second() const
      {
        return spun_ns > 0 ? static_cast<double>(count) / (1e-9 * static_cast<double>(spun_ns)) : 0;
      }
    };

    // Waits for an absolute time: sleeps to spin_ns before it, calls warm() (reads what the
    // work at that time will read), then spins on the clock: a busy vCPU is not descheduled
    // by its host, and a halted one may resume on a cold host core. Returns the time it left
    // the wait (ns).
    //
    // keep_warm: warm() again and again until one more pass would run past the deadline, then
    // spin the rest. When the host takes the core away for tens of us it runs other work on
    // it, which evicts what the first warm-up read; the repeated passes read it back before
    // the tick. A pass that took over 2 us longer than the fastest is counted as a gap of
    // the difference (the spin's own test), so the interruption figures keep their meaning.
    template <class Warm>
    std::int64_t
    wait_for_tick(const std::int64_t deadline, const std::int64_t spin_ns, const Warm &warm,
                  Interruptions &seen, const bool keep_warm = false)
    {
      sleep_until_ns(deadline - spin_ns);
      if (!keep_warm)
        {
          warm();
          return seen.spin_to(deadline);
        }
      std::int64_t t = now_ns(), fastest = INT64_MAX;
      for (;;)
        {
          warm();
          const std::int64_t after = now_ns(), pass = after - t;
          fastest = std::min(fastest, pass);
          seen.passed(pass, fastest);
          t = after;
          if (t + 2 * fastest >= deadline)
            break;
        }
      return seen.spin_to(deadline);
    }

    // Stalls of a loop: runs of consecutive wake-ups more than a period late (the thread was
    // not running at its tick), counted once each, and the longest (us).
    struct Stalls
    {
      long   count = 0, late_ticks = 0;
      double longest_us = 0;
    };

    Stalls
    stalls_of(const std::vector<double> &late_us, const double period_us)
    {
      Stalls s;
      for (size_t n = 0; n < late_us.size(); ++n)
        if (late_us[n] > period_us)
          {
            s.count += n == 0 || late_us[n - 1] <= period_us;
            ++s.late_ticks;
            s.longest_us = std::max(s.longest_us, late_us[n]);
          }
      return s;
    }

    // The calling thread on one CPU and, where the system allows, at real-time priority.
    // Returns what was granted, for the report.
    std::string
    make_real_time(const int cpu, const int priority)
    {
      std::string granted;
      if (cpu >= 0)
        {
          cpu_set_t set;
          CPU_ZERO(&set);
          CPU_SET(cpu, &set);
          granted += pthread_setaffinity_np(pthread_self(), sizeof(set), &set) == 0
                       ? "pinned to CPU " + std::to_string(cpu)
                       : "not pinned (refused)";
        }
      else
        granted += "not pinned";
      sched_param param{};
      param.sched_priority = priority;
      granted += pthread_setschedparam(pthread_self(), SCHED_FIFO, &param) == 0
                   ? ", SCHED_FIFO " + std::to_string(priority)
                   : ", normal priority (SCHED_FIFO refused)";
      return granted;
    }

    struct Trajectory
    {
      std::vector<double> time; // s
      std::vector<Vec3>   tip;  // m
    };

    Trajectory
    read_trajectory(const std::string &path)
    {
      std::ifstream in(path);
      if (!in)
        throw InputError("--trajectory: cannot read " + path);
      std::string line;
      if (!std::getline(in, line))
        throw InputError("--trajectory: " + path + " is empty");
      std::vector<std::string> header;
      {
        std::stringstream ss(line);
        std::string       name;
        while (std::getline(ss, name, ','))
          header.push_back(name.substr(0, name.find_last_not_of(" \r") + 1));
      }
      std::array<int, 4> column{-1, -1, -1, -1};
      const std::array<const char *, 4> names{"time_s", "x_m", "y_m", "z_m"};
      for (int c = 0; c < 4; ++c)
        for (size_t h = 0; h < header.size(); ++h)
          if (header[h] == names[c])
            column[c] = static_cast<int>(h);
      for (int c = 0; c < 4; ++c)
        if (column[c] < 0)
          throw InputError("--trajectory: " + path + " has no column '" + names[c] +
                           "' (needs time_s,x_m,y_m,z_m)");
      Trajectory t;
      for (int row = 2; std::getline(in, line); ++row)
        {
          if (line.empty() || line == "\r")
            continue;
          std::vector<double> values;
          std::stringstream   ss(line);
          std::string         cell;
          while (std::getline(ss, cell, ','))
            {
              size_t used = 0;
              double v    = 0;
              try
                {
                  v = std::stod(cell, &used);
                }
              catch (const std::exception &)
                {
                  used = 0;
                }
              if (used == 0 || !std::isfinite(v))
                throw InputError("--trajectory: " + path + " line " + std::to_string(row) +
                                 ": '" + cell + "' is not a finite number");
              values.push_back(v);
            }
          if (values.size() != header.size())
            throw InputError("--trajectory: " + path + " line " + std::to_string(row) + " has " +
                             std::to_string(values.size()) + " values, the header " +
                             std::to_string(header.size()));
          if (!t.time.empty() && values[column[0]] <= t.time.back())
            throw InputError("--trajectory: " + path + " line " + std::to_string(row) +
                             ": time_s must increase");
          t.time.push_back(values[column[0]]);
          t.tip.push_back({values[column[1]], values[column[2]], values[column[3]]});
        }
      if (t.time.size() < 2)
        throw InputError("--trajectory: " + path + " needs at least two samples");
      return t;
    }

    Vec3
    tip_at(const Trajectory &t, const double time)
    {
      if (time <= t.time.front())
        return t.tip.front();
      if (time >= t.time.back())
        return t.tip.back();
      const size_t i = static_cast<size_t>(
        std::upper_bound(t.time.begin(), t.time.end(), time) - t.time.begin() - 1);
      const double w = (time - t.time[i]) / (t.time[i + 1] - t.time[i]);
      Vec3         x;
      for (int d = 0; d < 3; ++d)
        x[d] = (1 - w) * t.tip[i][d] + w * t.tip[i + 1][d];
      return x;
    }

    // Outward unit normal at an output vertex: the area-weighted mean of its triangles'.
    Vec3
    vertex_normal(const ModelFrame &m, const unsigned v)
    {
      Vec3 n{0, 0, 0};
      for (const auto &tri : m.triangles)
        if (tri[0] == v || tri[1] == v || tri[2] == v)
          {
            const auto &a = m.output_coordinates[tri[0]], &b = m.output_coordinates[tri[1]],
                       &c = m.output_coordinates[tri[2]];
            const Vec3 e{b[0] - a[0], b[1] - a[1], b[2] - a[2]},
              f{c[0] - a[0], c[1] - a[1], c[2] - a[2]};
            n[0] += e[1] * f[2] - e[2] * f[1];
            n[1] += e[2] * f[0] - e[0] * f[2];
            n[2] += e[0] * f[1] - e[1] * f[0];
          }
      const double l = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
      if (!(l > 0))
        throw InputError("play: vertex " + std::to_string(v) + " lies on no model triangle");
      return {n[0] / l, n[1] / l, n[2] / l};
    }

    double
    percentile(std::vector<double> v, const double p)
    {
      if (v.empty())
        return 0;
      std::sort(v.begin(), v.end());
      const size_t i = std::min(v.size() - 1, static_cast<size_t>(std::ceil(p * v.size())) - (p > 0));
      return v[i];
    }

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

    // Counts per log-spaced bin, 10 per decade from 0.01 us to 100 ms.
    struct Histogram
    {
      static constexpr int bins = 70;
      static double
      low(const int b)
      {
        return 0.01 * std::pow(10.0, b / 10.0);
      }
      static std::vector<double>
      count(const std::vector<double> &us)
      {
        std::vector<double> c(bins, 0.0);
        for (const double x : us)
          {
            const int b = x <= 0.01 ? 0 : static_cast<int>(std::floor(10 * std::log10(x / 0.01)));
            c[std::clamp(b, 0, bins - 1)] += 1;
          }
        return c;
      }
    };
  } // namespace

  int
  run_play(const PlayOptions &o, std::ostream &out)
  {
    // Inputs first, all checked before any work.
    if (!(o.display_hz > 0 && o.display_hz <= 10000))
      throw InputError("--display-hz must be in (0, 10000]");
    check_output_folder("--out", o.out_dir);
    const fs::path dir(o.out_dir);
    for (const auto &name :
         {"forces.csv", "surface_updates.csv", "histogram.csv", "summary.csv", "play.md"})
      check_output_file("--out", (dir / name).string(), {o.model, o.trajectory});
    OutputLock lock((dir / "play").string());
    const Trajectory trajectory = read_trajectory(o.trajectory);

    if (!o.quiet)
      out << "loading " << o.model << "\n" << std::flush;
    const ImpulseResponseModel model = load_model(o.model, {}, ModelParts::modal_realization);
    ModalModelOptions          mo;
    mo.surface_modes = std::min<unsigned>(o.surface_modes, std::max(1u, model.modes.n_modes));
    mo.force_modes   = o.force_modes == 0 ? 0 : std::max(o.force_modes, mo.surface_modes);
    const ModalModel modal = make_modal_model(model, mo);
    const double     tau   = model.time_step;
    const double     rate  = o.rate_hz > 0 ? o.rate_hz : 1 / tau;
    if (rate > 100000)
      throw InputError("--rate-hz must be at most 100000");
    const double speed = rate * tau; // trajectory time per real time

    // The probed vertex: given, or the input vertex nearest the first sample.
    unsigned vertex = 0;
    if (o.vertex >= 0)
      {
        if (o.vertex >= static_cast<long>(model.output_coordinates.size()) ||
            model.output_input_index[o.vertex] < 0)
          throw InputError("--vertex " + std::to_string(o.vertex) +
                           " is not a model input vertex (a probe can touch only inputs)");
        vertex = static_cast<unsigned>(o.vertex);
      }
    else
      {
        double best = 1e300;
        for (unsigned v = 0; v < model.output_coordinates.size(); ++v)
          if (model.output_input_index[v] >= 0)
            {
              double d = 0;
              for (int k = 0; k < 3; ++k)
                d += std::pow(model.output_coordinates[v][k] - trajectory.tip[0][k], 2);
              if (d < best)
                best = d, vertex = v;
            }
      }
    const Vec3 normal = vertex_normal(model, vertex), rest = model.output_coordinates[vertex];

    // Every step's probe, made before the loop.
    const double duration = trajectory.time.back() - trajectory.time.front();
    const long   n_steps  = static_cast<long>(std::floor(duration / tau + 1e-9));
    if (n_steps < 1)
      throw InputError("--trajectory: shorter than one model step (" + fmt(tau) + " s)");
    // The probe touches where the device crossed the rest surface: from then on it prescribes
    // the vertex's displacement as the device's motion since that crossing (continuous at
    // first touch, drags along while pressed), and lets go when the device is back outside.
    std::vector<ProbeTarget> probes(n_steps);
    std::vector<double>      present(n_steps);
    Vec3                     touch{0, 0, 0};
    for (long n = 0; n < n_steps; ++n)
      {
        const Vec3   tip   = tip_at(trajectory, trajectory.time.front() + (n + 1) * tau);
        ProbeTarget &p     = probes[n];
        double       depth = 0;
        for (int d = 0; d < 3; ++d)
          depth -= (tip[d] - rest[d]) * normal[d];
        p.n_patch           = 1;
        p.patch_vertices[0] = vertex;
        p.patch_weights[0]  = 1;
        p.present           = depth > 0;
        if (p.present && (n == 0 || !probes[n - 1].present))
          for (int d = 0; d < 3; ++d) // where the tip crossed the tangent plane
            touch[d] = tip[d] + depth * normal[d];
        for (int d = 0; d < 3; ++d)
          {
            p.direction[d]    = -normal[d];
            p.displacement[d] = p.present ? tip[d] - touch[d] : 0;
          }
        present[n] = p.present;
      }

    // With a virtual coupling each step's probe prescribes the coupling's target (from the
    // device now and one step before, and the vertex one step before) behind its compliance;
    // arithmetic only, done in the force loop. The device's own motion stays in `device`.
    const contact::Coupling coupling{o.coupling_stiffness, o.coupling_damping};
    std::vector<Vec3>       device(n_steps);
    for (long n = 0; n < n_steps; ++n)
      {
        device[n] = probes[n].displacement;
        if (!coupling.rigid())
          {
            probes[n].unilateral = true;
            probes[n].compliance = coupling.compliance(tau);
          }
      }
    const auto couple = [&](const long n, const Vec3 &u_before) {
      if (!coupling.rigid())
        probes[n].displacement =
          coupling.target(device[n], n > 0 ? device[n - 1] : Vec3{0, 0, 0}, u_before, tau);
      return &probes[n];
    };

    // Per-step records, and the deformation thread's, sized before the threads start.
    std::vector<double> force_x(n_steps), force_y(n_steps), force_z(n_steps),
      step_us(n_steps), late_us(n_steps);
    std::vector<std::int64_t> wake_ns(n_steps);
    const long display_ticks = static_cast<long>(std::ceil(n_steps / rate * o.display_hz)) + 2;
    const long frame_stride  = std::max<long>(1, (display_ticks + o.max_frames - 1) / std::max(1u, o.max_frames));
    std::vector<double>    update_us(display_ticks, 0.0), update_step(display_ticks, 0.0),
      warm_us(display_ticks, 0.0), frame_u;
    std::vector<long long> frame_step;
    frame_u.assign(static_cast<size_t>((display_ticks / frame_stride + 1)) * model.n_outputs, 0.0);
    frame_step.assign(display_ticks / frame_stride + 1, 0);
    long                n_updates = 0, n_warms = 0, n_frames = 0, display_tick_count = 0;
    // What each thread's spins saw of its CPU (room for 64 gaps per frame, 4 per tick).
    Interruptions display_seen(static_cast<size_t>(display_ticks) * 64),
      force_seen(static_cast<size_t>(n_steps) * 4), baseline_seen(static_cast<size_t>(n_steps) * 4);
    std::vector<double> surface(model.n_outputs);
    if (mlockall(MCL_CURRENT | MCL_FUTURE) != 0 && !o.quiet)
      out << "note: memory not locked (mlockall refused); page faults may add latency\n";

    ModalInteraction                runtime(modal);
    TripleBuffer<ModalSurfaceState> exchange(make_surface_state(modal));
    std::atomic<bool>               force_done{false};
    long                            missed = 0;
    std::string                     force_rt, display_rt;
    const int                       n_cpus = static_cast<int>(std::thread::hardware_concurrency());
    const std::int64_t period_ns = static_cast<std::int64_t>(std::llround(1e9 / rate));
    const std::int64_t display_ns = static_cast<std::int64_t>(std::llround(1e9 / o.display_hz));
    const std::int64_t warm_ns =
      std::min(display_ns / 2, static_cast<std::int64_t>(std::llround(1e3 * o.warm_us)));
    const double       spin_us    = o.spin_us < 0 ? 0.9e6 / rate : std::min(o.spin_us, 1e6 / rate);
    const std::int64_t spin_ns    = static_cast<std::int64_t>(std::llround(1e3 * spin_us));
    // The clock starts once both threads run where they should (creating a thread under
    // mlockall faults in its whole stack, tens of ms on this VM), and 10 ms later.
    std::atomic<int>          threads_ready{0};
    std::atomic<std::int64_t> start_at{0};
    const auto                wait_for_start = [&] {
      if (threads_ready.fetch_add(1) + 1 == 2)
        start_at.store(now_ns() + 10000000, std::memory_order_release);
      std::int64_t t;
      // Sleeps, not yields: a FIFO thread yielding on main's CPU would starve it.
      while ((t = start_at.load(std::memory_order_acquire)) == 0)
        std::this_thread::sleep_for(std::chrono::microseconds(100));
      return t;
    };

    if (!o.quiet)
      out << "playing " << n_steps << " steps at " << fmt(rate) << " Hz (" << fmt(n_steps / rate)
          << " s), display at " << fmt(o.display_hz) << " Hz, probe on vertex " << vertex << "\n"
          << std::flush;

    // The machine's own stalls, measured beside the run: the same force loop (CPU, priority,
    // sleep and spin) doing no work, just before and as long. A tick it wakes more than a
    // period late would be missed by any step; what the runtime misses beyond these is its own.
    std::vector<double> baseline_late_us(o.baseline ? n_steps : 0);
    if (o.baseline)
      {
        std::thread idle([&] {
          make_real_time(o.pin && n_cpus > 1 ? n_cpus - 1 : -1, 80);
          const std::int64_t start = now_ns() + 10000000;
          for (long n = 0; n < n_steps; ++n)
            {
              const std::int64_t deadline = start + n * period_ns;
              baseline_late_us[n] = 1e-3 * static_cast<double>(wait_for_tick(deadline, spin_ns, [] {}, baseline_seen) - deadline);
            }
        });
        idle.join();
      }

    std::thread force([&] {
      force_rt                 = make_real_time(o.pin && n_cpus > 1 ? n_cpus - 1 : -1, 80);
      const std::int64_t start = wait_for_start();
      for (long n = 0; n < n_steps; ++n)
        {
          const std::int64_t deadline = start + n * period_ns;
          const std::int64_t wake     = wait_for_tick(deadline, spin_ns, [&] {
            if (o.warm_step)
              runtime.warm_step();
          }, force_seen, o.warm_step && o.keep_warm);
          runtime.step(couple(n, runtime.probe_displacement(0)), 1);
          runtime.save_surface_state(exchange.back());
          exchange.publish();
          const std::int64_t done = now_ns();
          const auto        &f    = runtime.force(0);
          force_x[n] = f[0], force_y[n] = f[1], force_z[n] = f[2];
          wake_ns[n] = wake;
          step_us[n] = 1e-3 * static_cast<double>(done - wake);
          late_us[n] = 1e-3 * static_cast<double>(wake - deadline);
          if (done > deadline + period_ns)
            ++missed;
        }
      force_done.store(true, std::memory_order_release);
    });
    // Pieces of the shapes per warm-up pass when they are kept warm: about 10 kB each for
    // the cat's, read in under a microsecond, so that the gaps between clock reads stay
    // those of the spin.
    constexpr size_t warm_parts = 64;
    std::thread deformation([&] {
      display_rt               = make_real_time(o.pin && n_cpus > 1 ? 0 : -1, 70);
      const std::int64_t start = wait_for_start();
      for (long tick = 0; tick < display_ticks; ++tick)
        {
          const std::int64_t frame = start + tick * display_ns;
          // The first frame too: the clock starts 10 ms after both threads run, time enough.
          if (warm_ns > 0 && o.keep_warm)
            {
              // The shapes a piece at a time, round and round until the frame; the first
              // whole pass of each frame is the one timed.
              size_t       part = 0;
              std::int64_t from = 0;
              wait_for_tick(frame, warm_ns, [&] {
                if (from == 0)
                  from = now_ns();
                warm_surface(modal, part, warm_parts);
                if (++part == warm_parts)
                  {
                    if (from > 0 && n_warms < static_cast<long>(warm_us.size()))
                      warm_us[n_warms++] = 1e-3 * static_cast<double>(now_ns() - from);
                    from = -1, part = 0;
                  }
              }, display_seen, true);
            }
          else if (warm_ns > 0)
            wait_for_tick(frame, warm_ns, [&] {
              const std::int64_t t0 = now_ns();
              warm_surface(modal);
              if (n_warms < static_cast<long>(warm_us.size())) // one per frame; never past it
                warm_us[n_warms++] = 1e-3 * static_cast<double>(now_ns() - t0);
            }, display_seen);
          else
            sleep_until_ns(frame);
          const bool finished = force_done.load(std::memory_order_acquire);
          if (exchange.update())
            {
              const std::int64_t t0 = now_ns();
              surface_displacement(modal, exchange.front(), surface.data());
              update_us[n_updates]     = 1e-3 * static_cast<double>(now_ns() - t0);
              update_step[n_updates++] = static_cast<double>(exchange.front().steps);
              if (display_tick_count++ % frame_stride == 0)
                {
                  std::copy(surface.begin(), surface.end(),
                            &frame_u[static_cast<size_t>(n_frames) * model.n_outputs]);
                  frame_step[n_frames++] = exchange.front().steps;
                }
            }
          else if (finished)
            break;
        }
    });
    force.join();
    deformation.join();
    munlockall();

    // Period jitter: each tick's wake-to-wake time against the nominal period.
    std::vector<double> jitter_us;
    for (long n = 1; n < n_steps; ++n)
      jitter_us.push_back(1e-3 * static_cast<double>(wake_ns[n] - wake_ns[n - 1] - period_ns));
    std::vector<double> abs_jitter(jitter_us.size());
    std::transform(jitter_us.begin(), jitter_us.end(), abs_jitter.begin(),
                   [](double x) { return std::abs(x); });
    update_us.resize(n_updates);
    update_step.resize(n_updates);
    warm_us.resize(n_warms);
    for (Interruptions *seen : {&display_seen, &force_seen, &baseline_seen})
      seen->gap_us.resize(seen->count);
    // One line of the report per thread: how often its spins were interrupted, and for how long.
    const auto interruptions_text = [&](const Interruptions &seen) {
      return std::to_string(seen.count) + " gaps in " + fmt(1e-9 * static_cast<double>(seen.spun_ns)) +
             " s of spinning (" + fmt(seen.per_second()) + " per s; p50 " +
             fmt(percentile(seen.gap_us, 0.5)) + " us, p99 " + fmt(percentile(seen.gap_us, 0.99)) +
             " us, longest " + fmt(percentile(seen.gap_us, 1.0)) + " us)";
    };

    // The same probes offline with every mode in the force loop: the exact model (the modal
    // realization with all modes reproduces H and the FEM, tests/test_irdm.cc).
    double force_error = -1;
    if (o.check)
      {
        ModalModelOptions all = mo;
        all.force_modes       = 0;
        const ModalModel exact_model = mo.force_modes == 0 ? ModalModel{} : make_modal_model(model, all);
        ModalInteraction exact(mo.force_modes == 0 ? modal : exact_model);
        double           diff = 0, norm = 0;
        for (long n = 0; n < n_steps; ++n)
          {
            exact.step(couple(n, exact.probe_displacement(0)), 1);
            const auto &f  = exact.force(0);
            const Vec3  fr = {force_x[n], force_y[n], force_z[n]};
            for (int d = 0; d < 3; ++d)
              diff += std::pow(fr[d] - f[d], 2), norm += f[d] * f[d];
          }
        force_error = norm > 0 ? std::sqrt(diff / norm) : std::sqrt(diff);
      }

    // Outputs.
    std::vector<double> step_index(n_steps), time_s(n_steps), dx(n_steps), dy(n_steps), dz(n_steps);
    for (long n = 0; n < n_steps; ++n)
      {
        step_index[n] = static_cast<double>(n);
        time_s[n]     = (n + 1) * tau;
        dx[n]         = rest[0] + device[n][0];
        dy[n]         = rest[1] + device[n][1];
        dz[n]         = rest[2] + device[n][2];
      }
    write_csv((dir / "forces.csv").string(),
              {"step", "time_s", "device_x_m", "device_y_m", "device_z_m", "present", "force_x_N",
               "force_y_N", "force_z_N", "force_step_us", "wake_late_us"},
              {step_index, time_s, dx, dy, dz, present, force_x, force_y, force_z, step_us, late_us});
    {
      // Every surface update's latency, for percentiles pooled over repeated runs.
      std::vector<double> index(update_us.size());
      std::iota(index.begin(), index.end(), 0.0);
      write_csv((dir / "surface_updates.csv").string(), {"update", "steps", "surface_update_us"},
                {index, update_step, update_us});
    }
    {
      std::vector<double> lo(Histogram::bins), hi(Histogram::bins);
      for (int b = 0; b < Histogram::bins; ++b)
        lo[b] = Histogram::low(b), hi[b] = Histogram::low(b + 1);
      write_csv((dir / "histogram.csv").string(),
                {"bin_low_us", "bin_high_us", "force_step", "period_jitter_abs", "surface_update"},
                {lo, hi, Histogram::count(step_us), Histogram::count(abs_jitter),
                 Histogram::count(update_us)});
    }
    fs::create_directories(dir / "surface");
    std::ostringstream pvd;
    pvd << "<?xml version=\"1.0\"?>\n<VTKFile type=\"Collection\" version=\"0.1\">\n<Collection>\n";
    for (long f = 0; f < n_frames; ++f)
      {
        char name[64];
        std::snprintf(name, sizeof name, "surface_%04ld.vtu", f);
        write_text_file((dir / "surface" / name).string(),
                        vtu(model, &frame_u[static_cast<size_t>(f) * model.n_outputs]));
        pvd << "<DataSet timestep=\"" << frame_step[f] * tau << "\" file=\"" << name << "\"/>\n";
      }
    pvd << "</Collection>\n</VTKFile>\n";
    write_text_file((dir / "surface" / "surface.pvd").string(), pvd.str());

    const double count_present = static_cast<double>(std::count(present.begin(), present.end(), 1.0));
    double peak_force = 0;
    for (long n = 0; n < n_steps; ++n)
      peak_force = std::max(peak_force, std::sqrt(force_x[n] * force_x[n] + force_y[n] * force_y[n] +
                                                   force_z[n] * force_z[n]));
    const double missed_fraction = static_cast<double>(missed) / n_steps;
    // Why each deadline was missed: the step itself took longer than a period, or the thread
    // was not running at its tick (woken late). Consecutive late wake-ups of more than a period
    // are one stall of the machine (a descheduled vCPU), counted once with its length.
    const double period_us = 1e-3 * static_cast<double>(period_ns);
    long         missed_overrun = 0;
    for (long n = 0; n < n_steps; ++n)
      missed_overrun += step_us[n] > period_us;
    const Stalls stalls = stalls_of(late_us, period_us), baseline = stalls_of(baseline_late_us, period_us);
    const double achieved_display =
      n_updates > 0 ? n_updates / (static_cast<double>(n_steps) / rate) : 0;
    {
      // One row for scripts that gather many runs (scripts/play_study.sh).
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
                 "force_interruption_p50_us", "force_interruption_max_us", "keep_warm"},
                {one(rate), one(spin_us), one(static_cast<double>(n_steps)),
                 one(static_cast<double>(missed)), one(static_cast<double>(missed_overrun)),
                 one(static_cast<double>(missed - missed_overrun)),
                 one(static_cast<double>(stalls.count)), one(1e-3 * stalls.longest_us),
                 one(o.baseline ? static_cast<double>(baseline.late_ticks) : -1),
                 one(o.baseline ? static_cast<double>(baseline.count) : -1),
                 one(o.baseline ? 1e-3 * baseline.longest_us : -1), one(percentile(step_us, 0.5)),
                 one(percentile(step_us, 0.99)), one(percentile(step_us, 0.999)),
                 one(percentile(step_us, 1.0)), one(percentile(late_us, 0.5)),
                 one(percentile(late_us, 0.99)), one(percentile(abs_jitter, 0.99)),
                 one(percentile(update_us, 0.5)), one(percentile(update_us, 0.99)),
                 one(percentile(update_us, 1.0)), one(static_cast<double>(n_updates)),
                 one(peak_force), one(force_error), one(1e-3 * static_cast<double>(warm_ns)),
                 one(percentile(warm_us, 0.5)), one(percentile(warm_us, 0.99)),
                 one(o.warm_step ? 1 : 0), one(display_seen.per_second()),
                 one(percentile(display_seen.gap_us, 0.5)), one(percentile(display_seen.gap_us, 1.0)),
                 one(force_seen.per_second()), one(percentile(force_seen.gap_us, 0.5)),
                 one(percentile(force_seen.gap_us, 1.0)), one(o.keep_warm ? 1 : 0)});
    }
    std::ostringstream md;
    md << "# irdm play\n\n"
       << report_stamp() << "\n\n"
       << "Model `" << o.model << "`: " << model.n_inputs / 3 << " input vertices, "
       << model.n_outputs / 3 << " surface vertices, " << modal.force_modes << " of its "
       << modal.n_modes << " modes in the force loop"
       << (modal.force_modes == modal.n_modes ? " (all: the exact model's forces), "
                                              : " (the rest quasi-static: their static compliance joins the feed-through), ")
       << modal.surface_modes
       << " in the surface update plus the static correction; time step " << fmt(tau * 1e3)
       << " ms. Trajectory `" << o.trajectory << "`, " << fmt(duration) << " s; probe on vertex "
       << vertex << " at (" << fmt(rest[0], "%.4f") << ", " << fmt(rest[1], "%.4f") << ", "
       << fmt(rest[2], "%.4f") << ") m, outward normal (" << fmt(normal[0], "%.2f") << ", "
       << fmt(normal[1], "%.2f") << ", " << fmt(normal[2], "%.2f") << "), "
       << (coupling.rigid() ? std::string("rigid and bilateral")
                            : "coupled to the device by a spring of " + fmt(coupling.stiffness) +
                                " N/m and a damper of " + fmt(coupling.damping) +
                                " N s/m (implicit, unilateral on the coupled force)")
       << " while the device is behind the rest surface along it (" << fmt(100 * count_present / n_steps)
       << " % of the steps).\n\n"
       << "Force loop at " << fmt(rate) << " Hz (" << n_steps << " steps; one model step per tick, "
       << (std::abs(speed - 1) < 1e-9 ? "real time" : "the trajectory plays at " + fmt(speed) + "x real time")
       << "), " << force_rt << ", "
       << (spin_ns > 0 ? "sleeping to " + fmt(spin_us) + " us before each tick and spinning the rest"
                       : std::string("sleeping to each tick"))
       << (!o.warm_step ? std::string(", no warm-up of the step's data (--no-warm-step)")
           : o.keep_warm ? std::string(", reading the step's data into its cache again and again "
                                       "until the tick (warm_step)")
                         : std::string(", reading the step's data into its cache when it wakes "
                                       "(warm_step, --warm-once)"))
       << ". Deformation loop at " << fmt(o.display_hz) << " Hz, "
       << display_rt << "; it updated the surface " << n_updates << " times (" << fmt(achieved_display)
       << " Hz). Shared state: a triple buffer (irdm/surface_exchange.h). Machine: " << n_cpus
       << " CPUs.\n\n"
       << "| | p50 | p99 | p99.9 | max |\n|---|---|---|---|---|\n"
       << "| force step (us) | " << fmt(percentile(step_us, 0.5)) << " | " << fmt(percentile(step_us, 0.99))
       << " | " << fmt(percentile(step_us, 0.999)) << " | " << fmt(percentile(step_us, 1.0)) << " |\n"
       << "| loop period jitter, abs (us) | " << fmt(percentile(abs_jitter, 0.5)) << " | "
       << fmt(percentile(abs_jitter, 0.99)) << " | " << fmt(percentile(abs_jitter, 0.999)) << " | "
       << fmt(percentile(abs_jitter, 1.0)) << " |\n"
       << "| wake-up lateness (us) | " << fmt(percentile(late_us, 0.5)) << " | " << fmt(percentile(late_us, 0.99))
       << " | " << fmt(percentile(late_us, 0.999)) << " | " << fmt(percentile(late_us, 1.0)) << " |\n"
       << "| surface update (us) | " << fmt(percentile(update_us, 0.5)) << " | "
       << fmt(percentile(update_us, 0.99)) << " | " << fmt(percentile(update_us, 0.999)) << " | "
       << fmt(percentile(update_us, 1.0)) << " |\n"
       << "| surface warm-up, before each frame (us) | " << fmt(percentile(warm_us, 0.5)) << " | "
       << fmt(percentile(warm_us, 0.99)) << " | " << fmt(percentile(warm_us, 0.999)) << " | "
       << fmt(percentile(warm_us, 1.0)) << " |\n\n"
       << (warm_ns > 0 && o.keep_warm
             ? "The deformation thread wakes " + fmt(1e-3 * static_cast<double>(warm_ns)) +
                 " us before each frame (--warm-us) and reads the surface shapes into its "
                 "cache, in " + std::to_string(warm_parts) + " pieces, again and again until the "
                 "frame (warm_surface); the warm-up row is its first whole pass. The surface "
                 "update is the time from the newest force state to the surface.\n\n"
           : warm_ns > 0 ? "The deformation thread reads the surface shapes into its cache once, " +
                           fmt(1e-3 * static_cast<double>(warm_ns)) +
                           " us before each frame (warm_surface, --warm-us, --warm-once) and spins "
                           "to the frame; the surface update is the time from the newest force "
                           "state to the surface.\n\n"
                       : std::string("No warm-up (--warm-us 0): each update streams the shapes "
                                     "from wherever the cache left them.\n\n"))
       << "Interruptions seen by the threads' spins (a gap over 2 us between two clock reads: "
          "the thread did not run, because of an interrupt or the host): force thread "
       << interruptions_text(force_seen) << "; deformation thread " << interruptions_text(display_seen)
       << (o.baseline ? "; the baseline's force loop " + interruptions_text(baseline_seen) : std::string())
       << ". At these rates a step of the p50 length is interrupted in about "
       << fmt(100 * force_seen.per_second() * 1e-6 * percentile(step_us, 0.5))
       << " % of ticks and an update of the p50 length in about "
       << fmt(100 * display_seen.per_second() * 1e-6 * percentile(update_us, 0.5))
       << " % of frames: percentiles beyond those shares measure the machine as much as the work.\n\n"
       << "Missed deadlines (a step finished after the next tick was due): " << missed << " of "
       << n_steps << " (" << fmt(100 * missed_fraction) << " %): " << missed_overrun
       << " because the step took longer than a period, " << missed - missed_overrun
       << " because the thread was woken late; " << stalls.count
       << " stall(s) in which it was not running for more than a period"
       << (stalls.count > 0 ? " (the longest " + fmt(1e-3 * stalls.longest_us) + " ms)" : std::string())
       << ".\n\n";
    if (o.baseline)
      md << "Baseline, measured just before: the same loop (CPU, priority, sleep and spin) doing no "
         << "work for as many ticks woke more than a period late at " << baseline.late_ticks
         << " ticks (" << fmt(100.0 * baseline.late_ticks / n_steps) << " %), in " << baseline.count
         << " stall(s)"
         << (baseline.count > 0 ? ", the longest " + fmt(1e-3 * baseline.longest_us) + " ms" : std::string())
         << ": deadlines any step would miss on this machine at that time.\n\n";
    if (force_error >= 0)
      md << "Force against the exact model (the same probes offline with every mode in the "
         << "force loop; relative L2 over the run): " << fmt(force_error)
         << (modal.force_modes == modal.n_modes ? " (the same model: a determinism check)" : "")
         << ". Peak force " << fmt(peak_force) << " N.\n\n";
    md << "Files: `forces.csv` (per step: device, force, force_step_us, wake_late_us), "
       << "`summary.csv` (these figures in one row; force_error and baseline_* -1: not run), "
       << "`surface_updates.csv` (per surface update: the force step it showed, its "
       << "surface_update_us), `histogram.csv` (log bins, 10 per decade), `surface/surface.pvd` (" << n_frames
       << " VTU frames of the deformed surface for ParaView; displacement_m per vertex).\n";
    write_text_file((dir / "play.md").string(), md.str());
    out << md.str();
    return missed_fraction > 0.001 ? 3 : 0;
  }
} // namespace irdm::play
