/// libFuzzer target: the options YAML (--config files and config/*.yaml) read into the three
/// modules' options and validated. Errors must be exceptions, never a crash.
#include <stdexcept>

#include <yaml-cpp/yaml.h>

#include "dypho/mapping/mapping_options_fields.h"
#include "dypho/mask/mask_options_fields.h"
#include "dypho/pipeline/options_yaml.h"
#include "dypho/tracking/tracking_options_fields.h"

namespace {

template <typename Options>
void readAndValidate(const YAML::Node& node) {
  Options options;
  dypho::pipeline::YamlOptionsReader reader(node, "fuzz");
  visitOptions(options, reader);
  reader.checkNoUnknownKeys();
  options.validate();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  try {
    const YAML::Node root = YAML::Load(std::string(reinterpret_cast<const char*>(data), size));
    if (!root.IsMap()) return 0;
    try {
      readAndValidate<dypho::mask::DynamicMaskOptions>(root["mask"]);
    } catch (const std::exception&) {
    }
    try {
      readAndValidate<dypho::tracking::TrackingOptions>(root["tracking"]);
    } catch (const std::exception&) {
    }
    try {
      readAndValidate<dypho::mapping::MappingOptions>(root["mapping"]);
    } catch (const std::exception&) {
    }
  } catch (const std::exception&) {
  }
  return 0;
}
