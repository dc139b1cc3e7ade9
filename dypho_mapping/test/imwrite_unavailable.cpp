/// For the portable CUDA trainer test (scripts/gpu_check.sh prepare): GPU machines without
/// OpenCV's image codecs (libopencv_imgcodecs pulls GDAL, VTK and more) still run the trainer
/// test, which never writes an image. If anything does call it, the test stops loudly.
#include <cstdio>
#include <cstdlib>

#include <opencv2/core.hpp>

namespace cv {
bool imwrite(const String& filename, InputArray, const std::vector<int>&) {
  std::fprintf(stderr, "imwrite(%s): this portable test build has no image codecs\n", filename.c_str());
  std::abort();
}
}  // namespace cv
