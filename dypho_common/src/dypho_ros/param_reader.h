#pragma once
/// \file param_reader.h
/// Reads a core Options struct from private ROS parameters through the struct's field visitor
/// (`visitOptions(options, visitor)`, declared next to each Options struct), so the list of keys is
/// written once. Unknown private keys are an error: a typo must not silently keep a default.

#include <cstddef>
#include <cstdint>
#include <type_traits>
#include <set>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include <ros/ros.h>

namespace dypho::ros_conversions {

class RosParamReader {
 public:
  explicit RosParamReader(const ros::NodeHandle& pnh) : pnh_(pnh) {}

  template <typename T>
  void operator()(const std::string& key, T& value, const char* /*doc*/) {
    known_.insert(key);
    if constexpr (std::is_same_v<T, std::size_t>) {
      int v = static_cast<int>(value);
      read(key, v);
      if (v < 0) throw std::invalid_argument("~" + key + " must be >= 0");
      value = static_cast<std::size_t>(v);
    } else if constexpr (std::is_same_v<T, float>) {
      double v = value;
      read(key, v);
      value = static_cast<float>(v);
    } else if constexpr (std::is_same_v<T, std::uint32_t>) {
      int v = static_cast<int>(value);
      read(key, v);
      if (v < 0) throw std::invalid_argument("~" + key + " must be >= 0");
      value = static_cast<std::uint32_t>(v);
    } else {
      read(key, value);
    }
    std::ostringstream s;
    s << value;
    summary_ += "\n  " + key + ": " + s.str();
  }

  /// Throws std::invalid_argument listing private parameters that no visitor asked for.
  void checkNoUnknownKeys() const {
    std::vector<std::string> names;
    ros::NodeHandle(pnh_).getParamNames(names);
    const std::string prefix = pnh_.getNamespace() + "/";
    std::string unknown;
    for (const std::string& name : names) {
      if (name.rfind(prefix, 0) != 0) continue;
      const std::string key = name.substr(prefix.size());
      if (key.find('/') != std::string::npos) continue;  // sub-namespaces belong to libraries
      if (known_.count(key) == 0) unknown += " " + key;
    }
    if (!unknown.empty()) {
      throw std::invalid_argument("unknown private parameter(s) in " + pnh_.getNamespace() + ":" + unknown +
                                  " (typo? see config/*.yaml for the valid keys)");
    }
  }

  /// "key: value" lines of everything read, for the startup log.
  const std::string& summary() const { return summary_; }

 private:
  /// Reads ~key into `value` when it is set; a value of the wrong type is an error, as in the
  /// YAML reader (it never silently keeps the default).
  template <typename V>
  void read(const std::string& key, V& value) const {
    if (!pnh_.hasParam(key)) return;
    V v = value;
    if (!pnh_.getParam(key, v)) {
      throw std::invalid_argument("~" + key +
                                  " has a value of the wrong type (check config/*.yaml and the launch file)");
    }
    value = v;
  }

  ros::NodeHandle pnh_;
  std::set<std::string> known_;
  std::string summary_;
};

}  // namespace dypho::ros_conversions
