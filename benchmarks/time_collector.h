#pragma once
// A console reporter that also keeps each benchmark's time per iteration (in its unit), for the
// ratios the benchmarks print side by side in one run.
#include <benchmark/benchmark.h>

#include <string>
#include <utility>
#include <vector>

namespace irdm_bench
{
  class TimeCollector : public benchmark::ConsoleReporter
  {
  public:
    std::vector<std::pair<std::string, double>> times; // name, time in the benchmark's unit
    void
    ReportRuns(const std::vector<Run> &runs) override
    {
      for (const auto &r : runs)
        if (r.run_type == Run::RT_Iteration && !r.error_occurred)
          times.emplace_back(r.benchmark_name(), r.GetAdjustedRealTime());
      ConsoleReporter::ReportRuns(runs);
    }
  };
} // namespace irdm_bench
