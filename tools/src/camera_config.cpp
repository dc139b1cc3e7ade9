#include "dypho/tools/camera_config.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>
#include <stdexcept>
#include <type_traits>

#include <yaml-cpp/yaml.h>

namespace fs = std::filesystem;

namespace dypho::tools {
namespace {

const std::vector<std::string> kRequiredKeys = {"name", "width", "height",     "fx",         "fy",
                                                "cx",   "cy",    "distortion", "depth_scale"};
/// Keys a camera file may leave out (their defaults are in CameraConfig).
const std::vector<std::string> kOptionalKeys = {"rolling_shutter_readout_ms"};

std::string joined(const std::vector<std::string>& names) {
  std::string out;
  for (const auto& n : names) out += (out.empty() ? "" : ", ") + n;
  return out.empty() ? "(none)" : out;
}

template <typename T>
T readScalar(const YAML::Node& root, const std::string& key, const std::string& path) {
  const YAML::Node node = root[key];
  if (!node.IsScalar()) {
    throw std::runtime_error("camera config '" + path + "': key '" + key + "' must be a scalar");
  }
  try {
    return node.as<T>();
  } catch (const YAML::Exception&) {
    throw std::runtime_error("camera config '" + path + "': key '" + key + "' has value '" + node.Scalar() +
                             "', which is not a valid " + (std::is_integral<T>::value ? "integer" : "number"));
  }
}

void requirePositive(double value, const std::string& key, const std::string& path) {
  if (!(value > 0.0) || !std::isfinite(value)) {
    throw std::runtime_error("camera config '" + path + "': key '" + key + "' must be > 0 (got " +
                             std::to_string(value) + ")");
  }
}

std::string lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return std::tolower(c); });
  return s;
}

/// "freiburg1"/"fr1" (and 2, 3) in `text` -> "tum_frN"; checks the long form first.
std::optional<std::string> tumCameraFromText(const std::string& text) {
  const std::string t = lower(text);
  for (const char n : {'1', '2', '3'}) {
    if (t.find(std::string("freiburg") + n) != std::string::npos) return std::string("tum_fr") + n;
  }
  for (const char n : {'1', '2', '3'}) {
    const std::string key = std::string("fr") + n;
    for (std::size_t pos = t.find(key); pos != std::string::npos; pos = t.find(key, pos + 1)) {
      // Require a word boundary so that e.g. "frame12" or "fr10" do not match.
      const bool start_ok = pos == 0 || !std::isalpha(static_cast<unsigned char>(t[pos - 1]));
      const std::size_t end = pos + key.size();
      const bool end_ok = end == t.size() || !std::isdigit(static_cast<unsigned char>(t[end]));
      if (start_ok && end_ok) return std::string("tum_fr") + n;
    }
  }
  return std::nullopt;
}

}  // namespace

CameraConfig loadCameraConfig(const std::string& yaml_path) {
  if (!fs::is_regular_file(yaml_path)) {
    throw std::runtime_error("camera config '" + yaml_path +
                             "' does not exist (pass a file path or a name from config/cameras/)");
  }
  YAML::Node root;
  try {
    root = YAML::LoadFile(yaml_path);
  } catch (const YAML::Exception& e) {
    throw std::runtime_error("camera config '" + yaml_path + "' is not valid YAML: " + e.what());
  }
  if (!root.IsMap()) {
    throw std::runtime_error("camera config '" + yaml_path + "' must be a YAML map with keys " + joined(kRequiredKeys));
  }
  for (const auto& kv : root) {
    const std::string key = kv.first.as<std::string>();
    if (std::find(kRequiredKeys.begin(), kRequiredKeys.end(), key) == kRequiredKeys.end() &&
        std::find(kOptionalKeys.begin(), kOptionalKeys.end(), key) == kOptionalKeys.end()) {
      throw std::runtime_error("camera config '" + yaml_path + "': unknown key '" + key + "' (allowed keys: " +
                               joined(kRequiredKeys) + "; optional: " + joined(kOptionalKeys) + ")");
    }
  }
  for (const auto& key : kRequiredKeys) {
    if (!root[key]) {
      throw std::runtime_error("camera config '" + yaml_path + "': missing key '" + key + "'");
    }
  }

  CameraConfig cfg;
  cfg.name = readScalar<std::string>(root, "name", yaml_path);
  cfg.camera.width = readScalar<int>(root, "width", yaml_path);
  cfg.camera.height = readScalar<int>(root, "height", yaml_path);
  cfg.camera.fx = readScalar<double>(root, "fx", yaml_path);
  cfg.camera.fy = readScalar<double>(root, "fy", yaml_path);
  cfg.camera.cx = readScalar<double>(root, "cx", yaml_path);
  cfg.camera.cy = readScalar<double>(root, "cy", yaml_path);
  cfg.depth_scale = readScalar<double>(root, "depth_scale", yaml_path);
  if (root["rolling_shutter_readout_ms"]) {
    cfg.rolling_shutter_readout_ms = readScalar<double>(root, "rolling_shutter_readout_ms", yaml_path);
    if (!(cfg.rolling_shutter_readout_ms >= 0.0 && cfg.rolling_shutter_readout_ms <= 100.0)) {
      throw std::runtime_error("camera config '" + yaml_path + "': rolling_shutter_readout_ms must be in [0, 100]");
    }
  }

  const YAML::Node dist = root["distortion"];
  if (!dist.IsSequence() || dist.size() != 5) {
    throw std::runtime_error("camera config '" + yaml_path +
                             "': key 'distortion' must be a list of 5 numbers [k1, k2, p1, p2, k3]");
  }
  for (std::size_t i = 0; i < 5; ++i) {
    try {
      cfg.camera.distortion[i] = dist[i].as<double>();
    } catch (const YAML::Exception&) {
      throw std::runtime_error("camera config '" + yaml_path + "': distortion[" + std::to_string(i) +
                               "] is not a number");
    }
  }

  if (cfg.name.empty()) throw std::runtime_error("camera config '" + yaml_path + "': 'name' is empty");
  requirePositive(cfg.camera.width, "width", yaml_path);
  requirePositive(cfg.camera.height, "height", yaml_path);
  requirePositive(cfg.camera.fx, "fx", yaml_path);
  requirePositive(cfg.camera.fy, "fy", yaml_path);
  requirePositive(cfg.depth_scale, "depth_scale", yaml_path);
  if (!std::isfinite(cfg.camera.cx) || !std::isfinite(cfg.camera.cy)) {
    throw std::runtime_error("camera config '" + yaml_path + "': cx/cy must be finite");
  }
  return cfg;
}

std::string defaultConfigDir() {
  if (const char* env = std::getenv("DYPHO_CONFIG_DIR"); env != nullptr && env[0] != '\0') {
    return env;
  }
  const std::string source_dir = DYPHO_TOOLS_SOURCE_CONFIG_DIR;
  if (fs::is_directory(source_dir)) return source_dir;
  const std::string install_dir = DYPHO_TOOLS_INSTALL_CONFIG_DIR;
  if (fs::is_directory(install_dir)) return install_dir;
  return source_dir;
}

std::vector<std::string> listCameraNames(const std::string& config_dir) {
  std::vector<std::string> names;
  const fs::path dir = fs::path(config_dir) / "cameras";
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) return names;
  for (const auto& e : fs::directory_iterator(dir, ec)) {
    if (e.is_regular_file() && e.path().extension() == ".yaml") names.push_back(e.path().stem().string());
  }
  std::sort(names.begin(), names.end());
  return names;
}

std::string resolveCameraConfig(const std::string& name_or_path, const std::string& config_dir) {
  if (fs::is_regular_file(name_or_path)) return name_or_path;
  const fs::path candidate = fs::path(config_dir) / "cameras" / (name_or_path + ".yaml");
  if (fs::is_regular_file(candidate)) return candidate.string();
  throw std::runtime_error("unknown camera '" + name_or_path + "': not a file and not in '" +
                           (fs::path(config_dir) / "cameras").string() +
                           "'; known names: " + joined(listCameraNames(config_dir)) + " (or set DYPHO_CONFIG_DIR)");
}

std::optional<std::string> detectCameraName(const std::string& dataset_dir) {
  const fs::path dir(dataset_dir);
  const fs::path own = dir / "camera.yaml";
  if (fs::is_regular_file(own)) return own.string();

  // TUM text files carry "# file: 'rgbd_dataset_freiburg1_rpy.bag'" in their header.
  std::ifstream rgb(dir / "rgb.txt");
  std::string line;
  for (int n = 0; n < 10 && std::getline(rgb, line); ++n) {
    if (line.empty() || line[0] != '#') break;
    if (line.find("file:") != std::string::npos) {
      if (auto name = tumCameraFromText(line)) return name;
    }
  }

  std::error_code ec;
  fs::path canonical = fs::weakly_canonical(dir, ec);
  if (ec) canonical = dir;
  std::string folder = canonical.filename().string();
  if (folder.empty()) folder = canonical.parent_path().filename().string();
  if (auto name = tumCameraFromText(folder)) return name;
  if (lower(folder).find("bonn") != std::string::npos) return std::string("bonn");
  return std::nullopt;
}

}  // namespace dypho::tools
