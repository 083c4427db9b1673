// Replay scripts: TOML text -> ReplayScript with its scene compiled. A bad script must end
// in ReplayError; anything else is a finding. Scene and mesh paths resolve in
// tests/fuzz/data (scene.toml there is a small scene to name).
#include <cstddef>
#include <cstdint>
#include <string>

#include "ffd/replay_script.h"
#include "fuzz_support.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const ffd::SceneLimits limits = ffd_fuzz::scene_limits();
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    const ffd::LoadedReplay replay = ffd::parse_replay(text, "fuzz.toml", FFDSIM_FUZZ_DATA_DIR, limits);
    (void)replay;
  } catch (const ffd::ReplayError&) {
  }
  return 0;
}
