#pragma once
/// \file mask_pairing.h
/// Pairs each input frame with the dynamic mask of the same stamp, so that tracking keeps the
/// camera's rate while the mask runs on another thread (or host):
///  - a frame waits for its mask at most `max_wait_s`; then it goes on with the mask nearest in
///    time (`kCarried`, at most `max_carry_age_s` away) or without one (`kNone`), and says so;
///  - a mask of a later frame releases the earlier frames still waiting at once (the mask stage
///    skipped them: it never goes back);
///  - frames are released in stamp order; beyond `max_pending_frames` a waiting frame is dropped
///    and counted, so nothing piles up when tracking is slower than the camera. The one dropped
///    leaves the shortest gap between the frames around it: a backlog thins out every other frame
///    instead of losing a run of consecutive ones, which tracking bridges far worse (a fast turn
///    over ten missing frames can lose the track; ten frames missing every other one cost nothing:
///    docs/journal/benchmarks-2026.md section 29);
///  - a stamp earlier than the last released one (a looped bag, a restarted driver) forgets the
///    masks after it.
/// ROS-free; the tracking nodelet holds message pointers in it (no copies), the tests plain values.
/// Not thread-safe (the owner's lock).

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <deque>
#include <iterator>
#include <limits>
#include <map>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "dypho/common/types.h"

namespace dypho::tracking {

/// Where the mask a frame was tracked with came from.
enum class MaskSource : std::uint8_t {
  kMatched = 0,  ///< the mask of this frame
  kCarried = 1,  ///< the mask of the frame nearest in time (the frame's own did not come in time)
  kNone = 2,     ///< no mask (none near enough, or the graph runs without one)
};

inline const char* toString(MaskSource source) {
  switch (source) {
    case MaskSource::kMatched:
      return "matched";
    case MaskSource::kCarried:
      return "carried";
    default:
      return "none";
  }
}

struct MaskPairingOptions {
  /// Longest a frame waits for its own mask [s], >= 0. Default 0.1 (three frames at 30 Hz: the
  /// mask takes 15-40 ms per frame on 2 cores; a longer wait only adds latency).
  double max_wait_s = 0.1;
  /// Frames waiting at once (for their masks or for tracking), >= 1; a newer frame beyond it
  /// drops one of them (the file comment says which). Default 30 (1 s at 30 Hz): a machine that
  /// is slower than the camera for up to about a second (a loaded moment of a small CPU, a burst
  /// of keyframes in a crowd, each with a 60-80 ms local BA on 2 cores) costs latency, not
  /// frames, and catch-up mode drains the backlog afterwards. A longer backlog is thinned rather
  /// than tracked later still. With 16, a 2-core VM with a busy loop beside the graph dropped
  /// frames in 2 of 6 runs (docs/journal/benchmarks-2026.md).
  int max_pending_frames = 30;
  /// A mask further than this from the frame's stamp is not carried to it [s], >= 0. Default 0.2
  /// (six frames at 30 Hz; people move a few centimetres, within the mask's safety margin).
  double max_carry_age_s = 0.2;
  /// Stamps this close are the same frame [s], >= 0. Default 0.001.
  double same_stamp_tolerance_s = 0.001;

  void validate() const {
    if (!(max_wait_s >= 0)) throw std::invalid_argument("mask_max_wait_s must be >= 0");
    if (max_pending_frames < 1) throw std::invalid_argument("mask_max_pending_frames must be >= 1");
    if (!(max_carry_age_s >= 0)) throw std::invalid_argument("mask_max_carry_age_s must be >= 0");
    if (!(same_stamp_tolerance_s >= 0))
      throw std::invalid_argument("MaskPairingOptions::same_stamp_tolerance_s must be >= 0");
  }
};

/// Counters since the start (or reset()).
struct MaskPairingStats {
  std::uint64_t frames_in = 0;     ///< frames added
  std::uint64_t matched = 0;       ///< released with their own mask
  std::uint64_t carried = 0;       ///< released with a carried mask
  std::uint64_t without_mask = 0;  ///< released with none
  std::uint64_t dropped = 0;       ///< dropped because max_pending_frames were waiting
  std::uint64_t late_masks = 0;    ///< masks that came after their frame had gone on
};

template <class Frame, class Mask>
class MaskPairer {
 public:
  /// A frame ready for tracking.
  struct Ready {
    Timestamp stamp_ns = 0;
    Frame frame;
    Mask mask{};  ///< value-initialised when source is kNone
    MaskSource source = MaskSource::kNone;
    double waited_s = 0.0;  ///< from addFrame to release [s]
  };

  /// `expect_masks` = false: every frame goes on at once without a mask.
  explicit MaskPairer(const MaskPairingOptions& options = {}, bool expect_masks = true)
      : options_(options), expect_masks_(expect_masks) {
    options_.validate();
  }

  /// A new frame, arrived at `now_s` (a monotonic clock [s]). Returns the waiting frame dropped to
  /// make room (counted in stats().dropped; see frameToDrop()), else nothing.
  std::optional<Frame> addFrame(Timestamp stamp_ns, Frame frame, double now_s) {
    ++stats_.frames_in;
    if (last_released_ns_ && stamp_ns < *last_released_ns_) {  // time went back: a new run
      masks_.erase(masks_.upper_bound(stamp_ns), masks_.end());
      last_released_ns_.reset();
      newest_mask_ns_.reset();
      if (!masks_.empty()) newest_mask_ns_ = masks_.rbegin()->first;
    }
    pending_.push_back(Pending{stamp_ns, std::move(frame), now_s});
    std::optional<Frame> dropped;
    if (static_cast<int>(pending_.size()) > options_.max_pending_frames) {  // one frame added: one over at most
      const auto victim = pending_.begin() + static_cast<std::ptrdiff_t>(frameToDrop());
      dropped.emplace(std::move(victim->frame));
      pending_.erase(victim);
      ++stats_.dropped;
    }
    return dropped;
  }

  /// The mask of the frame stamped `stamp_ns`.
  void addMask(Timestamp stamp_ns, Mask mask) {
    if (last_released_ns_ && stamp_ns <= *last_released_ns_ && !isPending(stamp_ns)) ++stats_.late_masks;
    masks_[stamp_ns] = std::move(mask);
    newest_mask_ns_ = std::max(newest_mask_ns_.value_or(stamp_ns), stamp_ns);
    // Keep the masks that may still serve a frame: a few, near the newest.
    while (masks_.size() > 16) masks_.erase(masks_.begin());
  }

  /// The frames that may go on at `now_s`, oldest first: the leading waiting frames whose mask is
  /// here, whose wait is over, or for which a later frame's mask has come.
  std::vector<Ready> takeReady(double now_s) {
    std::vector<Ready> out;
    while (!pending_.empty()) {
      Pending& p = pending_.front();
      Ready r;
      r.stamp_ns = p.stamp_ns;
      r.waited_s = now_s - p.arrival_s;
      if (!expect_masks_) {
        r.source = MaskSource::kNone;
      } else if (auto own = find(p.stamp_ns, options_.same_stamp_tolerance_s)) {
        r.mask = own->second;
        r.source = MaskSource::kMatched;
      } else if (r.waited_s >= options_.max_wait_s || laterMaskArrived(p.stamp_ns)) {
        if (auto near = nearest(p.stamp_ns)) {
          r.mask = near->second;
          r.source = MaskSource::kCarried;
        } else {
          r.source = MaskSource::kNone;
        }
      } else {
        break;  // still waiting; the frames after it wait too (stamp order)
      }
      count(r.source);
      r.frame = std::move(p.frame);
      last_released_ns_ = p.stamp_ns;
      pending_.pop_front();
      out.push_back(std::move(r));
    }
    pruneMasks();
    return out;
  }

  /// Seconds from `now_s` until the oldest waiting frame's wait is over; empty when none waits.
  std::optional<double> secondsUntilDeadline(double now_s) const {
    if (pending_.empty()) return std::nullopt;
    return std::max(0.0, pending_.front().arrival_s + options_.max_wait_s - now_s);
  }

  std::size_t pending() const { return pending_.size(); }
  const MaskPairingStats& stats() const { return stats_; }
  const MaskPairingOptions& options() const { return options_; }

  /// Forgets frames and masks (not the counters).
  void clear() {
    pending_.clear();
    masks_.clear();
    last_released_ns_.reset();
    newest_mask_ns_.reset();
  }

 private:
  struct Pending {
    Timestamp stamp_ns;
    Frame frame;
    double arrival_s;
  };
  using MaskMap = std::map<Timestamp, Mask>;

  static Timestamp nanos(double s) { return static_cast<Timestamp>(s * 1e9); }

  /// The waiting frame whose removal leaves the shortest gap between its neighbours (the frame
  /// released last before the oldest; before any release the oldest has none, so it goes first);
  /// ties go to the oldest; never the newest, which has no later neighbour yet.
  std::size_t frameToDrop() const {
    std::size_t best = 0;
    Timestamp best_gap_ns = std::numeric_limits<Timestamp>::max();
    for (std::size_t i = 0; i + 1 < pending_.size(); ++i) {
      const Timestamp before_ns = i > 0 ? pending_[i - 1].stamp_ns : last_released_ns_.value_or(pending_[0].stamp_ns);
      const Timestamp gap_ns = pending_[i + 1].stamp_ns - before_ns;
      if (gap_ns < best_gap_ns) {
        best_gap_ns = gap_ns;
        best = i;
      }
    }
    return best;
  }

  bool isPending(Timestamp stamp_ns) const {
    for (const Pending& p : pending_) {
      if (std::llabs(p.stamp_ns - stamp_ns) <= nanos(options_.same_stamp_tolerance_s)) return true;
    }
    return false;
  }

  bool laterMaskArrived(Timestamp stamp_ns) const {
    return newest_mask_ns_ && *newest_mask_ns_ > stamp_ns + nanos(options_.same_stamp_tolerance_s);
  }

  std::optional<std::pair<Timestamp, Mask>> find(Timestamp stamp_ns, double tolerance_s) const {
    auto best = nearestIt(stamp_ns);
    if (best == masks_.end() || std::llabs(best->first - stamp_ns) > nanos(tolerance_s)) return std::nullopt;
    return *best;
  }

  std::optional<std::pair<Timestamp, Mask>> nearest(Timestamp stamp_ns) const {
    return find(stamp_ns, options_.max_carry_age_s);
  }

  typename MaskMap::const_iterator nearestIt(Timestamp stamp_ns) const {
    if (masks_.empty()) return masks_.end();
    auto after = masks_.lower_bound(stamp_ns);
    if (after == masks_.begin()) return after;
    auto before = std::prev(after);
    if (after == masks_.end()) return before;
    return (stamp_ns - before->first) <= (after->first - stamp_ns) ? before : after;
  }

  /// Masks older than what any waiting or future frame could carry.
  void pruneMasks() {
    if (!last_released_ns_) return;
    const Timestamp keep_from = *last_released_ns_ - nanos(options_.max_carry_age_s);
    while (masks_.size() > 1 && masks_.begin()->first < keep_from) masks_.erase(masks_.begin());
  }

  void count(MaskSource source) {
    switch (source) {
      case MaskSource::kMatched:
        ++stats_.matched;
        break;
      case MaskSource::kCarried:
        ++stats_.carried;
        break;
      default:
        ++stats_.without_mask;
        break;
    }
  }

  MaskPairingOptions options_;
  bool expect_masks_;
  std::deque<Pending> pending_;
  MaskMap masks_;
  std::optional<Timestamp> last_released_ns_;
  std::optional<Timestamp> newest_mask_ns_;
  MaskPairingStats stats_;
};

}  // namespace dypho::tracking
