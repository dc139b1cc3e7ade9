/// soak_runner: a long synthetic sequence through the in-process pipeline (frames rendered on the
/// fly, nothing on disk): resident memory, Gaussian count, queued mapping jobs and per-frame
/// latency over time, to show they stay bounded and flat.
///
///   soak_runner [--frames 10000] [--every 100] [--out soak.csv] [--plot soak.png]
///               [--mapping-mode deterministic|live]
///   soak_runner --plot-csv soak.csv --plot soak.png     (plot an earlier run's CSV)
///
/// One CSV row per `every` frames: frame, rss_mb, gaussians, keyframes (mapper), queued, latency
/// p50/p95 [ms] of the frames in that window (mask + tracking + hand-over to mapping, not the
/// rendering of the synthetic input), then the tracker's keyframes and map points. The plot shows the same over the
/// frames. The CSV is rewritten after every row, so a run stopped early keeps what it measured.
///
/// --mapping-mode: `deterministic` (default, the runner's policy: a keyframe waits for the previous
/// keyframe's training) or `live` (the graph's policy: mapping runs beside the frames and drops
/// the oldest queued keyframe when its queue is full).
#include <algorithm>
#include <chrono>
#include <fstream>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "dypho/common/atomic_file.h"
#include "soak_stats.h"
#include "dypho/pipeline/slam_pipeline.h"
#include "dypho/tools/camera_config.h"
#include "dypho/tools/synthetic_scene.h"
#include "help_flag.h"

namespace {

struct Row {
  int frame;
  double rss_mb, gaussians, keyframes, queued, p50_ms, p95_ms;
  double tracker_keyframes = 0, tracker_points = 0;
};

/// Five stacked panels (RSS, Gaussians, queued jobs, latency p50/p95, keyframes of mapping and
/// tracking) over the frame index.
void plot(const std::vector<Row>& rows, const std::string& path) {
  const int w = 900, h = 220, panels = 5, margin = 50;
  cv::Mat img(h * panels, w, CV_8UC3, cv::Scalar(255, 255, 255));
  const double max_frame = rows.empty() ? 1.0 : rows.back().frame;
  auto panel = [&](int index, const char* title, auto value, auto value2) {
    double top = 1e-9;
    for (const Row& r : rows) top = std::max({top, value(r), value2 ? value2(r) : 0.0});
    top *= 1.15;
    const int y0 = index * h;
    cv::rectangle(img, {margin, y0 + 20}, {w - 10, y0 + h - 25}, cv::Scalar(0, 0, 0));
    cv::putText(img, std::string(title) + " (max " + std::to_string(static_cast<long>(top / 1.15)) + ")",
                {margin + 5, y0 + 15}, cv::FONT_HERSHEY_SIMPLEX, 0.45, cv::Scalar(0, 0, 0));
    auto to_px = [&](double frame, double v) {
      return cv::Point(margin + static_cast<int>((w - 10 - margin) * frame / max_frame),
                       y0 + h - 25 - static_cast<int>((h - 45) * v / top));
    };
    for (std::size_t i = 1; i < rows.size(); ++i) {
      cv::line(img, to_px(rows[i - 1].frame, value(rows[i - 1])), to_px(rows[i].frame, value(rows[i])),
               cv::Scalar(200, 60, 0), 2);
      if (value2)
        cv::line(img, to_px(rows[i - 1].frame, value2(rows[i - 1])), to_px(rows[i].frame, value2(rows[i])),
                 cv::Scalar(0, 0, 200), 1);
    }
    cv::putText(img, "0", {margin - 15, y0 + h - 25}, cv::FONT_HERSHEY_SIMPLEX, 0.4, cv::Scalar(0, 0, 0));
    cv::putText(img, "frame " + std::to_string(static_cast<long>(max_frame)), {w - 110, y0 + h - 8},
                cv::FONT_HERSHEY_SIMPLEX, 0.4, cv::Scalar(0, 0, 0));
  };
  using F = double (*)(const Row&);
  panel(
      0, "resident memory [MB]", [](const Row& r) { return r.rss_mb; }, F(nullptr));
  panel(
      1, "Gaussians", [](const Row& r) { return r.gaussians; }, F(nullptr));
  panel(
      2, "mapping jobs queued", [](const Row& r) { return r.queued; }, F(nullptr));
  panel(
      3, "latency per frame [ms]: p50 blue, p95 red", [](const Row& r) { return r.p50_ms; },
      F([](const Row& r) { return r.p95_ms; }));
  panel(
      4, "keyframes: mapping blue, tracking red", [](const Row& r) { return r.keyframes; },
      F([](const Row& r) { return r.tracker_keyframes; }));
  cv::imwrite(path, img);
}

}  // namespace

/// What -h / --help prints (the usage of the file comment above).
const char* const kUsage =
    "usage: soak_runner [--frames 10000] [--every 100] [--out soak.csv] [--plot soak.png]\n"
    "                   [--mapping-mode deterministic|live]\n"
    "       soak_runner --plot-csv soak.csv --plot soak.png     (plot an earlier run's CSV)\n"
    "A long synthetic sequence through the in-process pipeline: resident memory, Gaussians, queued\n"
    "mapping jobs and per-frame latency every --every frames into the CSV, plotted to --plot.\n";

int main(int argc, char** argv) {
  if (dypho::bench::printHelpIfAsked(argc, argv, kUsage)) return 0;
  using namespace dypho;
  int frames = 10000, every = 100;
  std::string out = "soak.csv", plot_path = "soak.png", plot_csv;
  mapping::MappingMode mode = mapping::MappingMode::kDeterministic;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string k = argv[i], v = argv[i + 1];
    if (k == "--frames")
      frames = std::stoi(v);
    else if (k == "--every")
      every = std::stoi(v);
    else if (k == "--out")
      out = v;
    else if (k == "--plot")
      plot_path = v;
    else if (k == "--plot-csv")
      plot_csv = v;
    else if (k == "--mapping-mode" && (v == "deterministic" || v == "live"))
      mode = v == "live" ? mapping::MappingMode::kLive : mapping::MappingMode::kDeterministic;
    else {
      std::cerr << "unknown argument " << k << "\n";
      return 2;
    }
  }
  if (!plot_csv.empty()) {
    std::ifstream in(plot_csv);
    std::vector<Row> rows;
    std::string line;
    std::getline(in, line);  // header
    for (Row r{}; std::getline(in, line);) {
      char comma;
      std::istringstream ss(line);
      if (ss >> r.frame >> comma >> r.rss_mb >> comma >> r.gaussians >> comma >> r.keyframes >> comma >> r.queued >>
          comma >> r.p50_ms >> comma >> r.p95_ms) {
        if (ss >> comma >> r.tracker_keyframes >> comma >> r.tracker_points) {
        }  // older CSVs lack them
        rows.push_back(r);
      }
    }
    plot(rows, plot_path);
    std::cout << "plotted " << rows.size() << " rows to " << plot_path << "\n";
    return 0;
  }
  tools::SynthOptions so;
  so.frames = frames;
  so.people = 2;
  so.seed = 9;
  const tools::SyntheticScene scene(so);
  const pipeline::PipelineOptions options = pipeline::loadPipelineOptions(tools::defaultConfigDir(), "");
  pipeline::SlamPipeline slam(options, mode);
  std::vector<Row> rows;
  std::vector<double> window;
  auto writeCsv = [&] {
    writeFileAtomically(out, [&](std::ostream& os) {
      os << "frame,rss_mb,gaussians,keyframes,queued,p50_ms,p95_ms,tracker_keyframes,tracker_points\n";
      for (const Row& r : rows)
        os << r.frame << ',' << r.rss_mb << ',' << r.gaussians << ',' << r.keyframes << ',' << r.queued << ','
           << r.p50_ms << ',' << r.p95_ms << ',' << r.tracker_keyframes << ',' << r.tracker_points << '\n';
    });
  };
  for (int i = 0; i < frames; ++i) {
    const RgbdFrame frame = scene.render(i).frame;
    const auto t0 = std::chrono::steady_clock::now();
    slam.process(frame);
    window.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
    if ((i + 1) % every == 0 || i + 1 == frames) {
      const mapping::MappingStageStats s = slam.mapping().stats();
      rows.push_back({i + 1, bench::residentMb("/proc/self/statm"), static_cast<double>(s.gaussians.num_gaussians),
                      static_cast<double>(s.gaussians.num_keyframes), static_cast<double>(s.gaussians.queued),
                      bench::percentile(window, 0.5), bench::percentile(window, 0.95)});
      const tracking::TrackerMap& tracker_map = slam.tracking().odometry().map();
      rows.back().tracker_keyframes = static_cast<double>(tracker_map.keyframes().size());
      rows.back().tracker_points = static_cast<double>(tracker_map.points().size());
      window.clear();
      const Row& r = rows.back();
      std::cerr << "frame " << r.frame << ": rss " << r.rss_mb << " MB, " << r.gaussians << " Gaussians, "
                << r.keyframes << " keyframes, queued " << r.queued << ", p50 " << r.p50_ms << " ms, p95 " << r.p95_ms
                << " ms, tracker " << r.tracker_keyframes << " keyframes / " << r.tracker_points << " points\n";
      writeCsv();
    }
  }
  plot(rows, plot_path);
  std::cout << "soak: " << frames << " frames, " << out << ", " << plot_path << "\n";
  return 0;
}
