#pragma once
// Per-stage time distributions and counters over many steps, for reports and benchmarks.
// add() never allocates once reserve() has made room for the steps to come.
#include <string>
#include <vector>

#include "ffd/step.h"

namespace ffd {

// A distribution of per-step times: nearest-rank percentiles.
struct TimeSummary {
  double mean_us = 0.0, p50_us = 0.0, p99_us = 0.0, p999_us = 0.0, max_us = 0.0;
};
TimeSummary summarize_times(std::vector<std::int64_t> ns);

struct CounterSummary {
  double mean = 0.0;
  std::uint32_t max = 0;
};

class StepStatistics {
 public:
  void reserve(std::size_t steps);
  void add(const StepReport& report);
  std::size_t steps() const { return steps_; }
  // Stages that ran in at least one step.
  bool ran(Stage stage) const { return !stage_ns_[index(stage)].empty(); }
  TimeSummary stage_time(Stage stage) const;
  TimeSummary step_time() const;
  // Counters by name ("boxes_updated", "hash_entries", ...) for one stage.
  std::vector<std::pair<std::string, CounterSummary>> counters(Stage stage) const;
  bool all_finite() const { return all_finite_; }
  bool any_overflow() const { return any_overflow_; }
  double max_box_penetration_m() const { return max_box_penetration_m_; }

 private:
  static std::size_t index(Stage s) { return static_cast<std::size_t>(s); }
  std::size_t steps_ = 0;
  std::array<std::vector<std::int64_t>, kStageCount> stage_ns_;
  std::array<std::vector<StageCounters>, kStageCount> counters_;
  std::vector<std::int64_t> total_ns_;
  bool all_finite_ = true;
  bool any_overflow_ = false;
  double max_box_penetration_m_ = 0.0;
};


}  // namespace ffd
