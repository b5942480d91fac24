#pragma once
// What irdm play's real-time loops share, whatever the model (apps/play.cc, the impulse-response
// model's loops; apps/play_reduced.cc, the reduced nonlinear model's): the clock, sleeping and
// spinning to a tick, what a spin sees of its CPU, stalls, real-time scheduling, the device
// trajectory, percentiles and the latency histogram.
#include <irdm_common/error.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <pthread.h>
#include <sched.h>
#include <time.h>

namespace irdm::play
{
  using Vec3 = std::array<double, 3>;

  inline std::int64_t
  now_ns()
  {
    timespec t{};
    clock_gettime(CLOCK_MONOTONIC, &t);
    return static_cast<std::int64_t>(t.tv_sec) * 1000000000 + t.tv_nsec;
  }

  inline void
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
  inline std::int64_t
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

  inline Stalls
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
  inline std::string
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

  inline Trajectory
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

  /// Relative L2 of a force history a against b over the run (the absolute L2 where b is 0).
  inline double
  relative_l2(const std::vector<Vec3> &a, const std::vector<Vec3> &b)
  {
    double diff = 0, norm = 0;
    for (size_t k = 0; k < a.size(); ++k)
      for (int d = 0; d < 3; ++d)
        diff += std::pow(a[k][d] - b[k][d], 2), norm += b[k][d] * b[k][d];
    return norm > 0 ? std::sqrt(diff / norm) : std::sqrt(diff);
  }

  inline Vec3
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


  inline double
  percentile(std::vector<double> v, const double p)
  {
    if (v.empty())
      return 0;
    std::sort(v.begin(), v.end());
    const size_t i = std::min(v.size() - 1, static_cast<size_t>(std::ceil(p * v.size())) - (p > 0));
    return v[i];
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
  // Outward unit normal at a surface vertex: the area-weighted mean of its triangles'.
  inline Vec3
  outward_normal(const std::vector<Vec3> &X, const std::vector<std::array<unsigned, 3>> &triangles,
                 const unsigned v)
  {
    Vec3 n{0, 0, 0};
    for (const auto &t : triangles)
      if (t[0] == v || t[1] == v || t[2] == v)
        {
          const Vec3 &a = X[t[0]], &b = X[t[1]], &c = X[t[2]];
          const Vec3  e{b[0] - a[0], b[1] - a[1], b[2] - a[2]}, f{c[0] - a[0], c[1] - a[1], c[2] - a[2]};
          n[0] += e[1] * f[2] - e[2] * f[1];
          n[1] += e[2] * f[0] - e[0] * f[2];
          n[2] += e[0] * f[1] - e[1] * f[0];
        }
    const double l = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    if (!(l > 0))
      throw InputError("play: vertex " + std::to_string(v) + " lies on no surface triangle");
    return {n[0] / l, n[1] / l, n[2] / l};
  }
} // namespace irdm::play
