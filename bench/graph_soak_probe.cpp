/// graph_soak_probe: watches a running DyPho graph for a soak and writes a CSV in soak_runner's
/// format (so `soak_runner --plot-csv` plots it): one row per `every` tracking statuses.
///
///   graph_soak_probe --pid MANAGER_PID --out soak.csv [--every 100] [--expect FRAMES]
///
/// Columns: frame (statuses received), rss_mb (resident memory of the nodelet manager, from
/// /proc/PID/statm), gaussians (width x height of the latest /dypho/gaussian_cloud), keyframes
/// (statuses with is_keyframe), queued (always 0: the graph has no such counter yet), p50_ms /
/// p95_ms (latency of the statuses in the window: ROS time at arrival minus the frame's stamp,
/// i.e. from the bag's /clock; 10 ms resolution). Ends when `expect` statuses arrived, or 20 s
/// after the last one, or on Ctrl-C; the CSV is rewritten after every row.
///
/// At the end it prints a summary of the whole run (bench/realtime_graph.sh reads it): statuses,
/// trusted poses, keyframes, latency p50/p95, the manager's CPU use between the first and the
/// last status [% of one core], and the rate of /dypho/rendered/color.
#include <algorithm>
#include <fstream>
#include <iostream>
#include <string>
#include <vector>

#include <dypho_slam/MaskStatus.h>
#include <dypho_slam/TrackingStatus.h>
#include <ros/ros.h>
#include <sensor_msgs/Image.h>
#include <sensor_msgs/PointCloud2.h>

#include "dypho/common/atomic_file.h"
#include "soak_stats.h"
#include "help_flag.h"

/// What -h / --help prints (the usage of the file comment above).
const char* const kUsage =
    "usage: graph_soak_probe --pid MANAGER_PID --out soak.csv [--every 100] [--expect FRAMES]\n"
    "Watches a running DyPho graph: one CSV row (soak_runner's format) per --every tracking statuses\n"
    "with the nodelet manager's resident memory, Gaussians, keyframes and status latency; ends after\n"
    "--expect statuses, 20 s after the last one, or on Ctrl-C, and prints a summary of the run.\n";

int main(int argc, char** argv) {
  if (dypho::bench::printHelpIfAsked(argc, argv, kUsage)) return 0;
  ros::init(argc, argv, "graph_soak_probe", ros::init_options::AnonymousName);
  int pid = 0, every = 100, expect = 0;
  std::string out = "graph_soak.csv";
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string k = argv[i], v = argv[i + 1];
    if (k == "--pid")
      pid = std::stoi(v);
    else if (k == "--every")
      every = std::stoi(v);
    else if (k == "--expect")
      expect = std::stoi(v);
    else if (k == "--out")
      out = v;
    else {
      std::cerr << "unknown argument " << k << "\n";
      return 2;
    }
  }
  if (pid <= 0 || every <= 0) {
    std::cerr << "usage: graph_soak_probe --pid MANAGER_PID --out soak.csv [--every 100] [--expect FRAMES]\n";
    return 2;
  }
  ros::NodeHandle nh;
  struct Row {
    int frame;
    double rss, gaussians, keyframes, p50, p95;
  };
  std::vector<Row> rows;
  std::vector<double> window;
  int statuses = 0, keyframes = 0, trusted = 0, rendered = 0;
  dypho_slam::TrackingStatus last;  ///< the newest status: the tracking nodelet's own counters
  dypho_slam::MaskStatus last_mask;
  double gaussians = 0;
  std::vector<double> all_latencies_ms;
  const std::string stat_path = "/proc/" + std::to_string(pid) + "/stat";
  double cpu_first_s = -1, cpu_last_s = -1;
  ros::WallTime first_status, last_status = ros::WallTime::now(), first_rendered, last_rendered;
  auto writeCsv = [&] {
    dypho::writeFileAtomically(out, [&](std::ostream& os) {
      os << "frame,rss_mb,gaussians,keyframes,queued,p50_ms,p95_ms\n";
      for (const Row& r : rows)
        os << r.frame << ',' << r.rss << ',' << r.gaussians << ',' << r.keyframes << ",0," << r.p50 << ',' << r.p95
           << '\n';
    });
  };
  auto cloud_sub = nh.subscribe<sensor_msgs::PointCloud2>(
      "/dypho/gaussian_cloud", 1,
      [&](const sensor_msgs::PointCloud2ConstPtr& c) { gaussians = static_cast<double>(c->width) * c->height; });
  auto status_sub = nh.subscribe<dypho_slam::TrackingStatus>(
      "/dypho/tracking_status", 200, [&](const dypho_slam::TrackingStatusConstPtr& s) {
        last_status = ros::WallTime::now();
        if (statuses == 0) first_status = last_status;
        ++statuses;
        if (s->is_keyframe) ++keyframes;
        if (s->trusted && s->anchored) ++trusted;
        last = *s;
        const double cpu_s = dypho::bench::cpuSeconds(stat_path);
        if (cpu_s >= 0) {
          if (cpu_first_s < 0) cpu_first_s = cpu_s;
          cpu_last_s = cpu_s;
        }
        window.push_back((ros::Time::now() - s->header.stamp).toSec() * 1e3);
        all_latencies_ms.push_back(window.back());
        if (statuses % every == 0) {
          rows.push_back({statuses, dypho::bench::residentMb("/proc/" + std::to_string(pid) + "/statm"), gaussians,
                          static_cast<double>(keyframes), dypho::bench::percentile(window, 0.5),
                          dypho::bench::percentile(window, 0.95)});
          window.clear();
          const Row& r = rows.back();
          std::cerr << "status " << r.frame << ": rss " << r.rss << " MB, " << r.gaussians << " Gaussians, "
                    << r.keyframes << " keyframes, latency p50 " << r.p50 << " ms, p95 " << r.p95 << " ms\n";
          writeCsv();
        }
      });
  auto mask_sub = nh.subscribe<dypho_slam::MaskStatus>(
      "/dypho/mask/status", 200, [&](const dypho_slam::MaskStatusConstPtr& m) { last_mask = *m; });
  auto rendered_sub =
      nh.subscribe<sensor_msgs::Image>("/dypho/rendered/color", 2, [&](const sensor_msgs::ImageConstPtr&) {
        last_rendered = ros::WallTime::now();
        if (rendered++ == 0) first_rendered = last_rendered;
      });
  ros::WallRate rate(20);  // wall time: once the bag ends, /clock stops and a ROS-time rate would never wake
  while (ros::ok()) {
    ros::spinOnce();
    if (expect > 0 && statuses >= expect) break;
    if (statuses > 0 && (ros::WallTime::now() - last_status).toSec() > 20.0) break;
    rate.sleep();
  }
  writeCsv();
  std::cout << "graph_soak_probe: " << statuses << " statuses, " << rows.size() << " rows in " << out << "\n";
  const double span_s = statuses > 1 ? (last_status - first_status).toSec() : 0.0;
  const double rendered_span_s = rendered > 1 ? (last_rendered - first_rendered).toSec() : 0.0;
  std::cout << "statuses: " << statuses << " (trusted poses " << trusted << ", keyframes " << keyframes << ")\n"
            << "latency_ms: p50 " << dypho::bench::percentile(all_latencies_ms, 0.5) << " p95 "
            << dypho::bench::percentile(all_latencies_ms, 0.95) << "\n"
            << "manager_cpu_percent: "
            << (span_s > 0 && cpu_first_s >= 0 ? 100.0 * (cpu_last_s - cpu_first_s) / span_s : 0.0)
            << " % of one core (over " << span_s << " s)\n"
            << "rendered_views: " << rendered << " (" << (rendered_span_s > 0 ? (rendered - 1) / rendered_span_s : 0.0)
            << " Hz)\n"
            << "tracking_counters: " << last.frames_in << " in, " << last.frames_processed << " processed, "
            << last.frames_dropped << " dropped, " << last.frames_mask_carried << " with a carried mask, "
            << last.frames_without_mask << " without a mask, " << last.frames_caught_up << " caught up; tracking p50 "
            << last.tracking_p50_ms << " ms, p95 " << last.tracking_p95_ms << " ms\n"
            << "mask_counters: " << last_mask.frames_in << " in, " << last_mask.frames << " masked, "
            << last_mask.frames_dropped_busy << " skipped; latency p50 " << last_mask.latency_p50_ms << " ms, p95 "
            << last_mask.latency_p95_ms << " ms\n";
  return 0;
}
