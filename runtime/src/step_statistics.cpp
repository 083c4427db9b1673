#include "ffd/step_statistics.h"

#include <algorithm>
#include <cmath>

namespace ffd {

TimeSummary summarize_times(std::vector<std::int64_t> ns) {
  TimeSummary t;
  if (ns.empty()) return t;
  std::sort(ns.begin(), ns.end());
  auto at = [&](double pct) {
    const double rank = std::ceil(pct / 100.0 * static_cast<double>(ns.size()));
    return static_cast<double>(ns[static_cast<std::size_t>(std::clamp(rank, 1.0, static_cast<double>(ns.size()))) - 1]) * 1e-3;
  };
  double sum = 0.0;
  for (std::int64_t v : ns) sum += static_cast<double>(v);
  t.mean_us = sum / static_cast<double>(ns.size()) * 1e-3;
  t.p50_us = at(50.0);
  t.p99_us = at(99.0);
  t.p999_us = at(99.9);
  t.max_us = static_cast<double>(ns.back()) * 1e-3;
  return t;
}

void StepStatistics::reserve(std::size_t steps) {
  for (auto& v : stage_ns_) v.reserve(steps);
  for (auto& v : counters_) v.reserve(steps);
  total_ns_.reserve(steps);
}

void StepStatistics::add(const StepReport& report) {
  ++steps_;
  for (std::size_t s = 0; s < kStageCount; ++s) {
    if (report.stage_ns[s] < 0) continue;
    stage_ns_[s].push_back(report.stage_ns[s]);
    counters_[s].push_back(report.counters[s]);
  }
  total_ns_.push_back(report.total_ns);
  all_finite_ = all_finite_ && report.finite;
  any_overflow_ = any_overflow_ || report.hash_overflow;
  max_box_penetration_m_ = std::max(max_box_penetration_m_, report.max_box_penetration_m);
}

TimeSummary StepStatistics::stage_time(Stage stage) const { return summarize_times(stage_ns_[index(stage)]); }
TimeSummary StepStatistics::step_time() const { return summarize_times(total_ns_); }

std::vector<std::pair<std::string, CounterSummary>> StepStatistics::counters(Stage stage) const {
  struct Field {
    const char* name;
    std::uint32_t StageCounters::*member;
  };
  static constexpr Field kFields[] = {
      {"boxes_updated", &StageCounters::boxes_updated},       {"hash_entries", &StageCounters::hash_entries},
      {"inter_pairs_tested", &StageCounters::inter_pairs_tested}, {"self_pairs_tested", &StageCounters::self_pairs_tested},
      {"node_tests", &StageCounters::node_tests},             {"inter_contacts", &StageCounters::inter_contacts},
      {"self_contacts", &StageCounters::self_contacts},       {"plane_contacts", &StageCounters::plane_contacts},
      {"probe_contacts", &StageCounters::probe_contacts},     {"objects_asleep", &StageCounters::objects_asleep},
  };
  std::vector<std::pair<std::string, CounterSummary>> out;
  const std::vector<StageCounters>& samples = counters_[index(stage)];
  for (const Field& f : kFields) {
    CounterSummary c;
    double sum = 0.0;
    for (const StageCounters& s : samples) {
      sum += s.*f.member;
      c.max = std::max(c.max, s.*f.member);
    }
    c.mean = samples.empty() ? 0.0 : sum / static_cast<double>(samples.size());
    out.emplace_back(f.name, c);
  }
  return out;
}

}  // namespace ffd
