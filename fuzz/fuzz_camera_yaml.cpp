/// libFuzzer target: camera YAML files (config/cameras/*.yaml or a user's). Errors must be
/// exceptions naming the problem, never a crash.
#include <stdexcept>

#include "dypho/tools/camera_config.h"
#include "fuzz_input.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string path = dypho::fuzz::writeInput(data, size, ".yaml");
  try {
    dypho::tools::loadCameraConfig(path);
  } catch (const std::exception&) {
  }
  return 0;
}
