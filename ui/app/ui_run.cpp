#include "app/ui_run.h"

namespace ffd::ui {

void collect_result(Viewer& viewer, UiRunResult& result) {
  Session& session = viewer.session();
  session.stop();
  result.scene_path = session.scene_path();
  result.compute_ns = session.compute_ns();
  result.lateness_ns = session.lateness_ns();
  result.counters = session.counters();
  result.finite = session.history().finite;
  result.steps_at_level = session.history().steps_at_level;
  result.log = session.log();
  if (const RecordingStream* r = session.recording()) {
    result.recorded_commands = r->commands();
    result.recorded_hashes = r->hashes();
    result.recording_error = session.recording_error();
  }
  if (const RunExports* e = session.exports()) {
    result.exports_summary = e->summary();
    result.exports_error = e->error();
  }
  for (const ObjectModel& o : session.model().objects) result.model_object_names.push_back(o.name);
}

}  // namespace ffd::ui
