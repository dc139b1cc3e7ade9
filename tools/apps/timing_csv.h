#pragma once
/// \file timing_csv.h
/// dypho_run_dataset's timing.csv: one row per processed frame with the stage times, the tracking
/// state and the mask's figures (columns in the header line; caught_up = 1: tracked in catch-up mode,
/// without local BA, because frames waited behind it; position_sigma_mm: the largest standard
/// deviation of the camera centre its matches allow, PoseCovariance::maxPositionSigmaM, -1 when
/// the frame was not tracked against the map).

#include <iomanip>
#include <ostream>
#include <string>
#include <vector>

#include "dypho/common/atomic_file.h"
#include "dypho/pipeline/slam_pipeline.h"

namespace dypho::run_dataset {

/// One processed frame: its position, stamp [s], read time [ms], report and work [ms].
struct TimingRow {
  std::size_t index;
  double stamp_s;
  double load_ms;
  pipeline::FrameReport report;
  double total_ms;
};

/// Writes timing.csv atomically.
inline void writeTiming(const std::string& path, const std::vector<TimingRow>& rows) {
  writeFileAtomically(path, [&](std::ostream& os) {
    os << "frame,stamp_s,load_ms,render_ms,mask_ms,features_ms,matching_ms,pnp_ms,refine_ms,tracking_ms,"
          "mapping_ms,total_ms,state,is_keyframe,num_features,num_inliers,masked_fraction,rendered_depth_used,"
          "static_check_ms,static_agreement,static_corrected,moving_points_removed,moving_points_seen,dense_ms,"
          "dense_correction_m,caught_up,position_sigma_mm\n";
    os << std::fixed;
    for (const TimingRow& r : rows) {
      const auto& t = r.report.tracking;
      os << r.index << ',' << std::setprecision(6) << r.stamp_s << ',' << std::setprecision(3) << r.load_ms << ','
         << r.report.render_ms << ',' << r.report.mask_ms << ',' << t.times.features << ',' << t.times.matching << ','
         << t.times.pnp << ',' << t.times.refine << ',' << t.times.total << ',' << r.report.mapping_ms << ','
         << r.total_ms << ',' << tracking::toString(t.state) << ',' << (t.is_keyframe ? 1 : 0) << ',' << t.num_features
         << ',' << t.num_inliers << ',' << std::setprecision(4) << r.report.masked_fraction << ','
         << (r.report.rendered_depth_used ? 1 : 0) << ',' << std::setprecision(3) << t.times.static_check << ','
         << std::setprecision(4) << t.static_agreement << ',' << (t.static_check_corrected ? 1 : 0) << ','
         << t.num_moving_points_removed << ',' << t.moving_points_camera_m.size() << ',' << std::setprecision(3)
         << t.times.dense << ',' << std::setprecision(5) << t.dense_correction_m << ',' << (t.caught_up ? 1 : 0) << ','
         << std::setprecision(3) << (t.pose_covariance.valid ? 1e3 * t.pose_covariance.maxPositionSigmaM() : -1.0)
         << '\n';
    }
  });
}

}  // namespace dypho::run_dataset
