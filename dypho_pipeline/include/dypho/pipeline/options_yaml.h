#pragma once
/// \file options_yaml.h
/// Reads and writes core Options structs as YAML through their `visitOptions` field lists, so the
/// keys are written once (see dypho/<module>/*_options_fields.h). Used by the command-line tools;
/// the nodelets read the same keys from private ROS parameters.

#include <cstdint>
#include <iomanip>
#include <ostream>
#include <set>
#include <sstream>
#include <stdexcept>
#include <string>
#include <type_traits>

#include <yaml-cpp/yaml.h>

namespace dypho::pipeline {

/// Visitor that overwrites fields present in a YAML map. Unknown keys are an error
/// (`checkNoUnknownKeys`), so a typo never silently keeps a default.
class YamlOptionsReader {
 public:
  /// `node` must be a map (or null = nothing to read); `context` names it in error messages.
  YamlOptionsReader(YAML::Node node, std::string context) : node_(std::move(node)), context_(std::move(context)) {
    if (node_.IsDefined() && !node_.IsNull() && !node_.IsMap()) {
      throw std::runtime_error(context_ + ": expected a map of key: value");
    }
  }

  template <typename T>
  void operator()(const std::string& key, T& value, const char* /*doc*/) {
    known_.insert(key);
    if (!node_.IsDefined() || node_.IsNull() || !node_[key]) return;
    try {
      value = node_[key].as<T>();
    } catch (const YAML::Exception&) {
      throw std::runtime_error(context_ + ": key '" + key + "' has a value of the wrong type");
    }
  }

  void checkNoUnknownKeys() const {
    if (!node_.IsDefined() || node_.IsNull()) return;
    std::string unknown;
    for (const auto& kv : node_) {
      const std::string key = kv.first.as<std::string>();
      if (known_.count(key) == 0) unknown += " " + key;
    }
    if (!unknown.empty()) {
      throw std::runtime_error(context_ + ": unknown key(s):" + unknown +
                               " (see config/*.yaml or `dypho_run_dataset --print-config`)");
    }
  }

 private:
  YAML::Node node_;
  std::string context_;
  std::set<std::string> known_;
};

/// Visitor that prints "key: value  # doc" lines (valid YAML), indented by `indent` spaces.
class YamlOptionsWriter {
 public:
  explicit YamlOptionsWriter(std::ostream& out, int indent = 0) : out_(out), indent_(indent) {}

  template <typename T>
  void operator()(const std::string& key, const T& value, const char* doc) {
    out_ << std::string(indent_, ' ') << key << ": ";
    if constexpr (std::is_same_v<T, bool>) {
      out_ << (value ? "true" : "false");
    } else if constexpr (std::is_same_v<T, std::string>) {
      out_ << '"' << value << '"';
    } else if constexpr (std::is_floating_point_v<T>) {
      std::ostringstream s;
      s << std::setprecision(10) << value;
      std::string v = s.str();
      if (v.find_first_of(".eE") == std::string::npos) v += ".0";
      out_ << v;
    } else {
      out_ << value;
    }
    if (doc != nullptr && doc[0] != '\0') out_ << "  # " << doc;
    out_ << '\n';
  }

 private:
  std::ostream& out_;
  int indent_;
};

}  // namespace dypho::pipeline
