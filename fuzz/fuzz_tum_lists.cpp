/// libFuzzer target: the TUM/Bonn text readers (rgb.txt/depth.txt lists, groundtruth/trajectory
/// files). Malformed lines must be reported (skipped lines or an exception), never crash.
#include <stdexcept>
#include <vector>

#include "dypho/common/trajectory_io.h"
#include "dypho/tools/tum_dataset.h"
#include "fuzz_input.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string path = dypho::fuzz::writeInput(data, size, ".txt");
  std::vector<std::string> skipped;
  try {
    dypho::tools::readStampedFileList(path, &skipped);
  } catch (const std::runtime_error&) {
  }
  try {
    dypho::readTumTrajectory(path);
  } catch (const std::runtime_error&) {
  }
  return 0;
}
