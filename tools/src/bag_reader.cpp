// BagRgbdReader: TUM-style rosbag topics -> RgbdFrames, with rgb/depth association by stamp.
#include <algorithm>
#include <map>
#include <mutex>
#include <optional>
#include <sstream>
#include <stdexcept>

#include <rosbag/bag.h>
#include <rosbag/exceptions.h>
#include <rosbag/view.h>

#include "bag_conversions.h"
#include "dypho/tools/bag_io.h"

namespace dypho::tools {

namespace {
struct TopicInfo {
  std::string datatype;
  std::size_t messages = 0;
};
}  // namespace

struct BagRgbdReader::Impl {
  std::string path;
  BagTopics topics;
  std::unique_ptr<rosbag::Bag> bag;  // MessageInstances point into it: never moved
  std::map<std::string, TopicInfo> bag_topics;
  std::vector<rosbag::MessageInstance> rgb, depth;  // associated pairs, by colour stamp
  std::vector<Timestamp> stamps_ns;
  std::optional<CameraIntrinsics> camera;
  std::string camera_error;  // why camera() fails when `camera` is empty
  mutable std::mutex mutex;  // rosbag reads move the file position

  std::string topicList() const {
    std::ostringstream ss;
    bool first = true;
    for (const auto& [name, info] : bag_topics) {
      ss << (first ? "" : ", ") << name << " [" << info.datatype << "]";
      first = false;
    }
    return bag_topics.empty() ? std::string("none") : ss.str();
  }

  void requireTopic(const std::string& topic, const std::string& datatype, const char* role) const {
    const auto it = bag_topics.find(topic);
    if (it == bag_topics.end()) {
      throw std::runtime_error("bag '" + path + "' has no " + role + " topic '" + topic +
                               "'; topics in the bag: " + topicList() + " (pass the right name in BagTopics)");
    }
    if (it->second.datatype != datatype) {
      throw std::runtime_error("bag '" + path + "': topic '" + topic + "' has type " + it->second.datatype +
                               ", expected " + datatype);
    }
  }
};

namespace {

/// Message handles of one Image topic and (header stamp [ns], index) pairs sorted by stamp.
/// (MessageInstance is not assignable, so the handles stay in arrival order.)
struct ImageIndex {
  std::vector<rosbag::MessageInstance> messages;
  std::vector<std::pair<Timestamp, std::size_t>> by_stamp;
};

ImageIndex indexImages(const rosbag::Bag& bag, const std::string& topic) {
  ImageIndex out;
  rosbag::View view(bag, rosbag::TopicQuery(topic));
  for (const rosbag::MessageInstance& m : view) {
    const auto msg = m.instantiate<sensor_msgs::Image>();
    if (!msg) continue;
    out.by_stamp.emplace_back(bag_detail::fromRosTime(msg->header.stamp), out.messages.size());
    out.messages.push_back(m);
  }
  std::stable_sort(out.by_stamp.begin(), out.by_stamp.end());
  return out;
}

}  // namespace

BagRgbdReader::BagRgbdReader(const std::string& path, BagTopics topics, double max_dt_s)
    : impl_(std::make_unique<Impl>()) {
  Impl& s = *impl_;
  s.path = path;
  s.topics = std::move(topics);
  s.bag = std::make_unique<rosbag::Bag>();
  try {
    s.bag->open(path, rosbag::bagmode::Read);
  } catch (const rosbag::BagException& e) {
    throw std::runtime_error("cannot open bag '" + path + "': " + e.what() + " (check the path)");
  }
  try {
    rosbag::View all(*s.bag);
    for (const rosbag::ConnectionInfo* c : all.getConnections()) s.bag_topics[c->topic].datatype = c->datatype;
    for (const rosbag::MessageInstance& m : all) ++s.bag_topics[m.getTopic()].messages;
    s.requireTopic(s.topics.rgb, "sensor_msgs/Image", "colour");
    s.requireTopic(s.topics.depth, "sensor_msgs/Image", "depth");

    const auto rgb = indexImages(*s.bag, s.topics.rgb);
    const auto depth = indexImages(*s.bag, s.topics.depth);
    const Timestamp max_dt_ns = static_cast<Timestamp>(max_dt_s * 1e9);
    const auto& d = depth.by_stamp;
    for (const auto& [stamp, rgb_index] : rgb.by_stamp) {
      // Nearest depth stamp (binary search in the sorted list).
      const auto it = std::lower_bound(d.begin(), d.end(), std::make_pair(stamp, std::size_t{0}));
      std::optional<std::size_t> best;
      Timestamp best_dt = max_dt_ns + 1;
      for (auto c : {it, it == d.begin() ? d.end() : std::prev(it)}) {
        if (c == d.end()) continue;
        const Timestamp dt = std::abs(c->first - stamp);
        if (dt < best_dt) {
          best_dt = dt;
          best = c->second;
        }
      }
      if (!best) continue;
      s.rgb.push_back(rgb.messages[rgb_index]);
      s.depth.push_back(depth.messages[*best]);
      s.stamps_ns.push_back(stamp);
    }
    if (s.rgb.empty()) {
      throw std::runtime_error("bag '" + path + "': no message on '" + s.topics.rgb + "' (" +
                               std::to_string(rgb.messages.size()) + ") has a depth message on '" + s.topics.depth +
                               "' (" + std::to_string(depth.messages.size()) + ") within " + std::to_string(max_dt_s) +
                               " s; check the topics or raise max_dt_s");
    }
    const auto info = s.bag_topics.find(s.topics.camera_info);
    if (info == s.bag_topics.end()) {
      s.camera_error = "bag '" + path + "' has no camera_info topic '" + s.topics.camera_info +
                       "' (topics in the bag: " + s.topicList() + "); pass the intrinsics with --camera NAME_OR_YAML";
    } else {
      rosbag::View view(*s.bag, rosbag::TopicQuery(s.topics.camera_info));
      for (const rosbag::MessageInstance& m : view) {
        const auto msg = m.instantiate<sensor_msgs::CameraInfo>();
        if (!msg) {
          s.camera_error = "bag '" + path + "': topic '" + s.topics.camera_info + "' has type " + m.getDataType() +
                           ", expected sensor_msgs/CameraInfo; pass --camera NAME_OR_YAML";
        } else {
          s.camera = bag_detail::cameraFromMsg(*msg, s.topics.camera_info);
        }
        break;
      }
    }
  } catch (const rosbag::BagException& e) {
    throw std::runtime_error("reading bag '" + path + "' failed: " + e.what());
  }
}

BagRgbdReader::~BagRgbdReader() = default;

std::size_t BagRgbdReader::size() const { return impl_->rgb.size(); }

Timestamp BagRgbdReader::stampNs(std::size_t i) const {
  if (i >= size())
    throw std::out_of_range("BagRgbdReader: pair " + std::to_string(i) + " of " + std::to_string(size()));
  return impl_->stamps_ns[i];
}

CameraIntrinsics BagRgbdReader::camera() const {
  if (!impl_->camera) throw std::runtime_error(impl_->camera_error);
  return *impl_->camera;
}

void BagRgbdReader::setCamera(const CameraIntrinsics& camera) {
  if (!camera.valid()) throw std::runtime_error("BagRgbdReader::setCamera: invalid intrinsics");
  impl_->camera = camera;
}

std::vector<std::string> BagRgbdReader::describeTopics() const {
  std::vector<std::string> out;
  for (const auto& [name, info] : impl_->bag_topics) {
    out.push_back(name + " [" + info.datatype + "] (" + std::to_string(info.messages) + " msgs)");
  }
  return out;
}

RgbdFrame BagRgbdReader::load(std::size_t i) const {
  const Impl& s = *impl_;
  if (i >= size())
    throw std::out_of_range("BagRgbdReader: pair " + std::to_string(i) + " of " + std::to_string(size()));
  RgbdFrame f;
  f.camera = camera();
  sensor_msgs::ImageConstPtr rgb, depth;
  {
    std::lock_guard<std::mutex> lock(s.mutex);
    try {
      rgb = s.rgb[i].instantiate<sensor_msgs::Image>();
      depth = s.depth[i].instantiate<sensor_msgs::Image>();
    } catch (const rosbag::BagException& e) {
      throw std::runtime_error("reading bag '" + s.path + "' failed: " + e.what());
    }
  }
  f.stamp_ns = s.stamps_ns[i];
  f.bgr = bag_detail::colourFromMsg(*rgb, s.topics.rgb);
  f.depth_m = bag_detail::depthFromMsg(*depth, s.topics.depth);
  if (f.bgr.size() != f.depth_m.size()) {
    throw std::runtime_error("bag '" + s.path + "': colour is " + std::to_string(f.bgr.cols) + "x" +
                             std::to_string(f.bgr.rows) + " but depth is " + std::to_string(f.depth_m.cols) + "x" +
                             std::to_string(f.depth_m.rows) + "; depth must be registered to colour");
  }
  return f;
}

}  // namespace dypho::tools
