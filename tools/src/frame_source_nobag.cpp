// Built without ROS: bags cannot be read.
#include <stdexcept>

#include "dypho/tools/frame_source.h"

namespace dypho::tools {

std::unique_ptr<FrameSource> openBagFrameSource(const std::string& bag_path, const std::string&, const std::string&) {
  throw std::runtime_error("'" + bag_path + "': this build has no ROS, so bags cannot be read; " +
                           "convert the bag to a TUM folder or rebuild with catkin");
}

}  // namespace dypho::tools
