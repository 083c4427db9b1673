// Scene files: TOML text -> SceneSpec -> Model -> initial State. A bad file must end in the
// loader's or compile()'s error; anything else (another exception, a sanitizer report, a
// timeout, running out of memory) is a finding. Mesh paths resolve in tests/fuzz/data.
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "ffd/model.h"
#include "ffd/scene_loader.h"
#include "fuzz_support.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const ffd::SceneLimits limits = ffd_fuzz::scene_limits();
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    const ffd::SceneSpec spec = ffd::parse_scene(text, "fuzz.toml", FFDSIM_FUZZ_DATA_DIR, limits);
    std::vector<std::string> log;
    const ffd::Model model = ffd::compile(spec, log);
    const ffd::State state = ffd::initial_state(model);
    (void)state;
  } catch (const ffd::SceneError&) {
  } catch (const ffd::CompileError&) {
  }
  return 0;
}
