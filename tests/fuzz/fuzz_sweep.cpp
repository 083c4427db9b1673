// Sweep files: TOML text -> SweepPlan (its grid or points expanded, every value checked). A bad
// file must end in InputError; anything else is a finding. The replay it names is not loaded
// (fuzz_replay covers replay scripts).
#include <cstddef>
#include <cstdint>
#include <string>

#include "ffd/sweep.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    const ffd::SweepPlan plan = ffd::parse_sweep(text, "fuzz.toml", FFDSIM_FUZZ_DATA_DIR);
    for (const ffd::SweepJob& job : plan.jobs)
      for (const ffd::SweepValue& value : job.values) (void)ffd::sweep_value_text(value);
  } catch (const ffd::InputError&) {
  }
  return 0;
}
