/// libFuzzer target: the 3DGS .ply loader (a map file from anywhere: truncated, hostile counts,
/// wrong property types). Errors must be std::runtime_error, never a crash or a huge allocation.
#include <stdexcept>

#include "dypho/mapping/gaussian_map.h"
#include "dypho/mapping/gaussian_ply.h"
#include "fuzz_input.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string path = dypho::fuzz::writeInput(data, size, ".ply");
  dypho::mapping::GaussianMap map(3, 20000);
  try {
    std::string note;
    dypho::mapping::readGaussianPly(path, map, &note);
  } catch (const std::runtime_error&) {
  }
  return 0;
}
