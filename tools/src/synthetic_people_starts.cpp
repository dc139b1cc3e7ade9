// Walking people of the synthetic scene: where on their paths they start (at random, or in the
// first image and as little hidden by each other as the paths allow).
#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

#include "synthetic_internal.h"

namespace dypho::tools::synth_detail {
namespace {

/// Sampling step when looking for start times that put people into the first view [s].
constexpr double kStartStepS = 0.05;

struct Interval {
  double lo = 0.0, hi = 0.0, depth = 0.0;
};

/// Share of each interval not hidden by nearer ones; returns (min, mean) over `all`.
std::pair<double, double> visibleShares(const std::vector<Interval>& all) {
  double min_share = 1.0, sum = 0.0;
  for (std::size_t i = 0; i < all.size(); ++i) {
    std::vector<std::pair<double, double>> cover;
    for (std::size_t j = 0; j < all.size(); ++j) {
      if (j == i || all[j].depth >= all[i].depth) continue;
      const double lo = std::max(all[j].lo, all[i].lo), hi = std::min(all[j].hi, all[i].hi);
      if (hi > lo) cover.emplace_back(lo, hi);
    }
    std::sort(cover.begin(), cover.end());
    double hidden = 0.0, end = -std::numeric_limits<double>::infinity();
    for (const auto& c : cover) {
      if (c.second <= end) continue;
      hidden += c.second - std::max(c.first, end);
      end = c.second;
    }
    const double share = 1.0 - hidden / std::max(all[i].hi - all[i].lo, 1e-9);
    min_share = std::min(min_share, share);
    sum += share;
  }
  return {min_share, all.empty() ? 1.0 : sum / all.size()};
}

}  // namespace

// chooseStarts: what it does is said in synthetic_internal.h.
void chooseStarts(const SynthOptions& o, std::vector<PersonPath>& paths, const std::vector<std::vector<int>>& units,
                  cv::RNG& rng) {
  if (!o.people_in_view_at_start) {
    for (const auto& unit : units) {
      const double start_s = rng.uniform(0.0, paths[unit.front()].cycle_s);
      for (int m : unit) paths[m].start_s = start_s;
    }
    return;
  }
  const Eigen::Isometry3d T_world_camera = cameraPoseAt(o, 0.0);
  const double width = o.camera.width;
  std::vector<std::vector<Interval>> placed(units.size());  // image spans of each unit's members
  for (int pass = 0; pass < 3; ++pass) {
    for (std::size_t unit_index = 0; unit_index < units.size(); ++unit_index) {
      const std::vector<int>& unit = units[unit_index];
      std::vector<Interval> others;
      for (std::size_t j = 0; j < units.size(); ++j) {
        if (j != unit_index) others.insert(others.end(), placed[j].begin(), placed[j].end());
      }
      const double cycle_s = paths[unit.front()].cycle_s;
      const int samples = std::max(1, static_cast<int>(std::ceil(cycle_s / kStartStepS)));
      std::vector<double> keys(samples);
      std::vector<std::vector<Interval>> spans(samples);
      double best = -1.0;
      for (int i = 0; i < samples; ++i) {
        bool inside = true;
        double in_image = 1.0;
        for (int m : unit) {
          // At t = 0 the cycle time is the start time.
          const BodySpan s = bodySpan(legStateAt(paths[m], cycle_s * i / samples).position, T_world_camera, o.camera);
          inside = inside && s.inside;
          const double clipped = std::min(s.u_hi, width - 0.5) - std::max(s.u_lo, -0.5);
          in_image = std::min(in_image, s.in_front ? std::max(0.0, clipped) / std::max(s.u_hi - s.u_lo, 1e-9) : 0.0);
          spans[i].push_back({s.u_lo, s.u_hi, s.depth_m});
        }
        double key = in_image;
        if (inside) {
          std::vector<Interval> all = others;
          all.insert(all.end(), spans[i].begin(), spans[i].end());
          const auto [min_share, mean_share] = visibleShares(all);
          key = 1.0 + 0.8 * min_share + 0.2 * mean_share;
        }
        keys[i] = key;
        best = std::max(best, key);
      }
      std::vector<int> candidates;
      for (int i = 0; i < samples; ++i) {
        if (keys[i] >= best - 0.02) candidates.push_back(i);
      }
      const int pick = candidates[rng.uniform(0, static_cast<int>(candidates.size()))];
      for (int m : unit) paths[m].start_s = cycle_s * pick / samples;
      placed[unit_index] = spans[pick];
    }
  }
}

}  // namespace dypho::tools::synth_detail
