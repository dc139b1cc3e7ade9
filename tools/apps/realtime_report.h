#pragma once
/// \file realtime_report.h
/// dypho_run_dataset --realtime: realtime.csv (what happened to each frame) and the summary lines.

#include <algorithm>
#include <iomanip>
#include <sstream>
#include <string>
#include <vector>

#include "dypho/common/atomic_file.h"
#include "dypho/pipeline/realtime_runner.h"

namespace dypho::run_dataset {

/// realtime.csv: one row per frame of the sequence: what happened to it in the realtime run.
inline void writeRealtimeCsv(const std::string& path, const pipeline::RealtimeResult& r, std::size_t num_frames) {
  std::vector<std::string> fate(num_frames, "unreadable");  // never released: the loader failed
  std::vector<double> latency_ms(num_frames, -1.0);
  for (const pipeline::RealtimeProcessedFrame& f : r.processed) {
    fate[f.index] = f.report.dropped ? "rejected_stamp" : "posed";
    if (!f.report.dropped) latency_ms[f.index] = f.latency_ms;
  }
  for (std::size_t i : r.dropped_before_tracking) fate[i] = "dropped_before_tracking";
  if (r.stopped) {
    // Frames after a stop were never released.
    std::vector<bool> released(num_frames, false);
    for (const pipeline::RealtimeProcessedFrame& f : r.processed) released[f.index] = true;
    for (std::size_t i : r.dropped_before_tracking) released[i] = true;
    for (std::size_t i = 0; i < num_frames; ++i) {
      if (!released[i] && fate[i] == "unreadable") fate[i] = "not_released";
    }
  }
  writeFileAtomically(path, [&](std::ostream& os) {
    os << "frame,fate,latency_ms\n" << std::fixed << std::setprecision(3);
    for (std::size_t i = 0; i < num_frames; ++i) os << i << ',' << fate[i] << ',' << latency_ms[i] << '\n';
  });
}

/// The realtime run in two lines for the summary.
inline std::string realtimeSummary(const pipeline::RealtimeResult& r, std::size_t num_frames,
                                   const pipeline::RealtimeOptions& o) {
  const auto caught_up =
      std::count_if(r.processed.begin(), r.processed.end(),
                    [](const pipeline::RealtimeProcessedFrame& f) { return f.report.tracking.caught_up; });
  std::ostringstream os;
  os << std::fixed << "realtime:     " << r.frames_in << " frames in, " << r.processed.size() << " processed ("
     << r.framesPosed() << " posed, " << std::setprecision(3)
     << static_cast<double>(r.framesPosed()) / static_cast<double>(std::max<std::size_t>(num_frames, 1))
     << " of the sequence), " << r.framesDropped() << " dropped, no pose; " << caught_up
     << " in catch-up mode (no local BA); " << r.framesWithMask(tracking::MaskSource::kCarried)
     << " with a carried mask, " << r.masks_skipped.size() << " skipped by the mask; " << r.late_releases
     << " released late (reading fell behind)\n"
     << "latency:      " << std::setprecision(1) << r.latencyPercentileMs(0.5) << " ms p50, "
     << r.latencyPercentileMs(0.95) << " ms p95 (release to pose); speed x" << std::setprecision(2) << o.speed
     << ", mask queue " << o.queue_capacity_frames << ", " << std::setprecision(1) << r.wall_s
     << " s wall; per frame: realtime.csv";
  return os.str();
}

}  // namespace dypho::run_dataset
