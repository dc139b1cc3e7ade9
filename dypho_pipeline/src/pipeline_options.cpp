/// Pipeline options from config/*.yaml and an override file.
#include "dypho/pipeline/pipeline_options.h"

#include <stdexcept>

#include <yaml-cpp/yaml.h>

#include "dypho/mapping/mapping_options_fields.h"
#include "dypho/mask/mask_options_fields.h"
#include "dypho/pipeline/options_yaml.h"
#include "dypho/tracking/tracking_options_fields.h"

namespace dypho::pipeline {
namespace {

YAML::Node loadYamlFile(const std::string& path) {
  try {
    return YAML::LoadFile(path);
  } catch (const YAML::BadFile&) {
    throw std::runtime_error("cannot read config file '" + path + "' (does it exist?)");
  } catch (const YAML::Exception& e) {
    throw std::runtime_error("config file '" + path + "' is not valid YAML: " + e.what());
  }
}

template <typename Options>
void readSection(const YAML::Node& node, const std::string& context, Options& options) {
  YamlOptionsReader reader(node, context);
  visitOptions(options, reader);
  reader.checkNoUnknownKeys();
}

}  // namespace

MaskSource parseMaskSource(const std::string& name) {
  if (name == "flow") return MaskSource::kFlow;
  if (name == "external" || name == "gt") return MaskSource::kExternal;
  if (name == "none") return MaskSource::kNone;
  throw std::runtime_error("unknown mask source '" + name + "' (valid: flow, gt, none)");
}

PipelineOptions loadPipelineOptions(const std::string& config_dir, const std::string& override_yaml) {
  PipelineOptions options;
  readSection(loadYamlFile(config_dir + "/mask.yaml"), config_dir + "/mask.yaml", options.mask);
  readSection(loadYamlFile(config_dir + "/tracking.yaml"), config_dir + "/tracking.yaml", options.tracking);
  readSection(loadYamlFile(config_dir + "/mapping.yaml"), config_dir + "/mapping.yaml", options.mapping);
  if (!override_yaml.empty()) {
    const YAML::Node root = loadYamlFile(override_yaml);
    if (root.IsDefined() && !root.IsNull()) {
      if (!root.IsMap()) throw std::runtime_error(override_yaml + ": expected mask:/tracking:/mapping: maps");
      for (const auto& kv : root) {
        const std::string section = kv.first.as<std::string>();
        if (section != "mask" && section != "tracking" && section != "mapping") {
          throw std::runtime_error(override_yaml + ": unknown section '" + section +
                                   "' (valid: mask, tracking, mapping)");
        }
      }
      readSection(root["mask"], override_yaml + " [mask]", options.mask);
      readSection(root["tracking"], override_yaml + " [tracking]", options.tracking);
      readSection(root["mapping"], override_yaml + " [mapping]", options.mapping);
    }
  }
  try {
    options.mask.validate();
    options.tracking.validate();
    options.mapping.validate();
  } catch (const std::invalid_argument& e) {
    throw std::runtime_error(std::string("invalid option: ") + e.what());
  }
  return options;
}

void writePipelineOptionsYaml(std::ostream& out, PipelineOptions options) {
  out << "mask:\n";
  mask::visitOptions(options.mask, YamlOptionsWriter(out, 2));
  out << "tracking:\n";
  tracking::visitOptions(options.tracking, YamlOptionsWriter(out, 2));
  out << "mapping:\n";
  mapping::visitOptions(options.mapping, YamlOptionsWriter(out, 2));
}

}  // namespace dypho::pipeline
