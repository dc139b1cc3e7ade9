#include <gtest/gtest.h>

#include <functional>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include "dypho/mask/flow_mask_options.h"
#include "dypho/mask/mask_options_fields.h"

namespace dypho {
namespace mask {
namespace DYPHO_UNITY_ID {

TEST(FlowMaskOptions, DefaultsAreValidAndDocumentedValues) {
  const FlowMaskOptions o;
  EXPECT_NO_THROW(o.validate());
  // The defaults promised by the header and the brief.
  EXPECT_DOUBLE_EQ(o.flow_scale, 0.25);
  EXPECT_DOUBLE_EQ(o.residual_threshold_px, 2.0);
  EXPECT_EQ(o.min_region_area_px, 400);
  EXPECT_EQ(o.dilate_px, 8);
  EXPECT_DOUBLE_EQ(o.max_masked_fraction, 0.6);
}

TEST(FlowMaskOptions, ValidateRejectsEachBadValueAndNamesTheField) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  struct Case {
    std::string field;
    std::function<void(FlowMaskOptions&)> spoil;
  };
  const std::vector<Case> cases = {
      {"flow_scale", [](FlowMaskOptions& o) { o.flow_scale = 0.0; }},
      {"flow_scale", [](FlowMaskOptions& o) { o.flow_scale = 1.5; }},
      {"flow_scale", [nan](FlowMaskOptions& o) { o.flow_scale = nan; }},
      {"residual_threshold_px", [](FlowMaskOptions& o) { o.residual_threshold_px = 0.0; }},
      {"residual_threshold_px", [nan](FlowMaskOptions& o) { o.residual_threshold_px = nan; }},
      {"min_region_area_px", [](FlowMaskOptions& o) { o.min_region_area_px = -1; }},
      {"dilate_px", [](FlowMaskOptions& o) { o.dilate_px = -2; }},
      {"max_masked_fraction", [](FlowMaskOptions& o) { o.max_masked_fraction = 0.0; }},
      {"max_masked_fraction", [](FlowMaskOptions& o) { o.max_masked_fraction = 1.01; }},
      {"open_radius_px", [](FlowMaskOptions& o) { o.open_radius_px = -1; }},
      {"sample_step_px", [](FlowMaskOptions& o) { o.sample_step_px = 0; }},
      {"ransac_threshold_px", [](FlowMaskOptions& o) { o.ransac_threshold_px = -1.0; }},
      {"ransac_max_iterations", [](FlowMaskOptions& o) { o.ransac_max_iterations = 0; }},
      {"min_inlier_ratio", [](FlowMaskOptions& o) { o.min_inlier_ratio = 1.0; }},
      {"min_texture_gradient", [](FlowMaskOptions& o) { o.min_texture_gradient = -1.0; }},
      {"dis_refinement_iterations", [](FlowMaskOptions& o) { o.dis_refinement_iterations = -1; }},
      {"dis_refinement_iterations", [](FlowMaskOptions& o) { o.dis_refinement_iterations = 101; }},
  };
  for (const Case& c : cases) {
    FlowMaskOptions o;
    c.spoil(o);
    try {
      o.validate();
      ADD_FAILURE() << "validate() accepted a bad " << c.field;
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(c.field), std::string::npos) << e.what();
    }
  }
}

TEST(FlowMaskOptions, ToStringListsEveryField) {
  const std::string s = FlowMaskOptions().toString();
  for (const char* key :
       {"flow_scale=", "residual_threshold_px=", "min_region_area_px=", "dilate_px=", "max_masked_fraction=",
        "open_radius_px=", "sample_step_px=", "ransac_threshold_px=", "ransac_max_iterations=", "min_inlier_ratio=",
        "min_texture_gradient=", "ultrafast=", "dis_refinement_iterations="}) {
    EXPECT_NE(s.find(key), std::string::npos) << key << " missing in " << s;
  }
}

TEST(FlowMaskOptions, VisitOptionsCoversEveryFieldOfToString) {
  // visitOptions (the key list used by parameter readers) and toString() must list the same keys.
  FlowMaskOptions o;
  const std::string printed = o.toString();
  std::size_t visited = 0;
  visitOptions(o, [&](const char* key, auto& /*field*/, const char* doc) {
    ++visited;
    EXPECT_NE((" " + printed).find(std::string(" ") + key + "="), std::string::npos) << key;
    EXPECT_GT(std::string(doc).size(), 10u) << key;
  });
  std::size_t printed_keys = 0;
  for (char c : printed) printed_keys += c == '=' ? 1 : 0;
  EXPECT_EQ(visited, printed_keys);
}

}  // namespace DYPHO_UNITY_ID
}  // namespace mask
}  // namespace dypho
