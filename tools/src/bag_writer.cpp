// BagRgbdWriter: RgbdFrames -> rosbag topics (TUM, RealSense or OpenNI2 layout).
#include <stdexcept>

#include <rosbag/bag.h>
#include <rosbag/exceptions.h>

#include "bag_conversions.h"
#include "dypho/tools/bag_io.h"

namespace dypho::tools {

struct BagRgbdWriter::Impl {
  rosbag::Bag bag;
  BagTopics topics;
  std::string path;
  bool open = false;
  std::size_t frames = 0;
};

BagRgbdWriter::BagRgbdWriter(const std::string& path, BagTopics topics) : impl_(std::make_unique<Impl>()) {
  bag_detail::checkWritableEncodings(topics.colour_encoding, topics.depth_encoding);
  impl_->topics = std::move(topics);
  impl_->path = path;
  try {
    impl_->bag.open(path, rosbag::bagmode::Write);
  } catch (const rosbag::BagException& e) {
    throw std::runtime_error("cannot create bag '" + path + "': " + e.what() +
                             " (does the folder exist and is it writable?)");
  }
  impl_->open = true;
}

BagRgbdWriter::~BagRgbdWriter() {
  try {
    close();
  } catch (...) {  // destructor must not throw; close() reports errors to callers who call it
  }
}

void BagRgbdWriter::write(const RgbdFrame& f) {
  if (!impl_->open) throw std::runtime_error("BagRgbdWriter: write() after close() on '" + impl_->path + "'");
  if (f.bgr.type() != CV_8UC3 || f.depth_m.type() != CV_32FC1 || f.bgr.size() != f.depth_m.size()) {
    throw std::runtime_error("BagRgbdWriter: need bgr CV_8UC3 and depth_m CV_32FC1 of the same size");
  }
  if (!f.camera.valid()) throw std::runtime_error("BagRgbdWriter: frame has no valid camera intrinsics");
  std_msgs::Header header;
  header.seq = static_cast<std::uint32_t>(impl_->frames);
  header.stamp = bag_detail::toRosTime(f.stamp_ns);
  header.frame_id = impl_->topics.frame_id;
  try {
    const BagTopics& t = impl_->topics;
    impl_->bag.write(t.rgb, header.stamp, bag_detail::colourToMsg(f.bgr, header, t.colour_encoding));
    impl_->bag.write(t.depth, header.stamp, bag_detail::depthToMsg(f.depth_m, header, t.depth_encoding));
    impl_->bag.write(impl_->topics.camera_info, header.stamp, bag_detail::cameraToMsg(f.camera, header));
  } catch (const rosbag::BagException& e) {
    throw std::runtime_error("writing bag '" + impl_->path + "' failed: " + e.what());
  }
  ++impl_->frames;
}

void BagRgbdWriter::close() {
  if (!impl_ || !impl_->open) return;
  impl_->open = false;
  try {
    impl_->bag.close();
  } catch (const rosbag::BagException& e) {
    throw std::runtime_error("closing bag '" + impl_->path + "' failed: " + e.what());
  }
}

std::size_t BagRgbdWriter::framesWritten() const { return impl_->frames; }

}  // namespace dypho::tools
