#include "json_report.h"

#include <cstdio>

namespace ffdsim {

nlohmann::json time_summary_json(const ffd::TimeSummary& t) {
  return {{"mean_us", t.mean_us}, {"p50_us", t.p50_us}, {"p99_us", t.p99_us}, {"p99_9_us", t.p999_us}, {"max_us", t.max_us}};
}

nlohmann::json make_report(const ffd::Model& model, const RunSummary& run, const ffd::StepStatistics& stats) {
  using nlohmann::json;
  json report;
  report["scene"] = run.scene;
  report["steps"] = run.steps;
  report["dt_s"] = run.dt;
  report["state_hash"] = ffd::hash_hex(run.state_hash);
  report["finite"] = run.finite;
  report["max_penetration_m"] = run.contacts.max_penetration_m;
  report["max_gap_m"] = run.contacts.max_gap_m;
  json contacts = json::array();
  for (const ffd::SurfaceContact& c : run.contacts.contacts)
    contacts.push_back({{"a", c.a}, {"b", c.b}, {"penetration_m", c.penetration_m}, {"gap_m", c.gap_m}});
  report["contacts"] = contacts;
  report["surface_intersections"] = {{"between_objects", run.intersections.between},
                                     {"within_objects", run.intersections.within},
                                     {"rest_crossings", run.rest_intersections}};
  report["max_box_penetration_m"] = stats.max_box_penetration_m();
  report["hash_overflow"] = stats.any_overflow();
  report["energy"] = {{"kinetic_j", run.energy.kinetic},
                      {"gravitational_j", run.energy.gravitational},
                      {"elastic_j", run.energy.elastic},
                      {"total_j", run.energy.total()}};
  json effects = json::array();
  for (ffd::Effect e : ffd::kAllEffects)
    if (ffd::has(model.settings.effects, e)) effects.push_back(ffd::effect_name(e));
  report["effects"] = effects;
  json sizes;
  sizes["objects"] = model.objects.size();
  sizes["lattice_nodes"] = model.node_count();
  sizes["cells"] = model.cell_count();
  sizes["ffd_aabbs"] = model.box_count();
  sizes["springs"] = model.springs.size();
  sizes["regions"] = model.regions.size();

  report["model"] = sizes;
  json stages = json::object();
  json pipeline = json::array();
  for (ffd::Stage stage : model.pipeline) {
    pipeline.push_back(ffd::stage_name(stage));
    json s = time_summary_json(stats.stage_time(stage));
    json counters = json::object();
    for (const auto& [name, c] : stats.counters(stage))
      if (c.max > 0) counters[name] = {{"mean", c.mean}, {"max", c.max}};
    s["counters"] = counters;
    stages[ffd::stage_name(stage)] = s;
  }
  report["pipeline"] = pipeline;
  report["stages"] = stages;
  report["step"] = time_summary_json(stats.step_time());
  return report;
}

}  // namespace ffdsim
