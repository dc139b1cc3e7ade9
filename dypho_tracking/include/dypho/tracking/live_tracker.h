#pragma once
/// \file live_tracker.h
/// Tracking as a live graph runs it: frames come from the camera, their dynamic masks from a mask
/// stage on another thread (or host), both at their own pace. One implementation for the tracking
/// nodelet (inputs are message pointers) and the pipeline's RealtimeRunner (`dypho_run_dataset
/// --realtime`, plain frames), so the offline live numbers measure the graph's own code.
///
///  - addFrame()/addMask() (the callers' threads, a short lock) feed a MaskPairer: a frame waits
///    for its own mask at most `max_wait_s`, then goes on with a carried mask or none; beyond
///    `max_pending_frames` waiting frames one is dropped and counted, thinning a backlog every
///    other frame (mask_pairing.h).
///  - The preparing thread (`dypho_features`) takes the paired frames in stamp order, converts
///    each with the caller's function and extracts its features (FeaturePreparer), while
///  - the tracking thread (`dypho_tracking`) tracks the previous one (TrackingStage::process) and
///    hands the result to the caller's sink. One prepared frame waits between them at most
///    (BoundedHandOver::pushWhenRoom: the pairer's bound does the dropping).
///  - Tracking is told how far the mask judged the frame (liveJudgement()); frames waiting behind
///    a frame (pairer and hand-over) put tracking in catch-up mode (RgbdOdometry::track).
///  - A conversion or tracking error drops that frame only: it goes to the failure sink (on the
///    thread where it happened) and the next frames go on.
/// Counters and live figures: counters(), statistics(). Frames are conserved: once finish() or
/// stop() returned, frames_in == frames_processed + frames_dropped + frames_discarded, and every
/// processed frame reached the sink or the failure sink.
/// ROS-free; thread-safe.

#include <condition_variable>
#include <cstdint>
#include <exception>
#include <functional>
#include <mutex>
#include <optional>
#include <stdexcept>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include <opencv2/core.hpp>

#include "dypho/common/bounded_hand_over.h"
#include "dypho/common/rolling_stats.h"
#include "dypho/common/thread_budget.h"
#include "dypho/common/types.h"
#include "dypho/tracking/feature_preparer.h"
#include "dypho/tracking/mask_pairing.h"
#include "dypho/tracking/tracking_stage.h"

namespace dypho::tracking {

/// A paired frame in core types, as the caller's conversion gives it.
struct LiveFrame {
  RgbdFrame frame;  ///< images, stamp, camera
  cv::Mat mask;     ///< CV_8UC1 of the image's size, 255 = dynamic; empty = all static
  /// How the frame's own mask judged it, used when the pairer matched it (a flow mask's first
  /// frame without a network did not judge it). Default kJudged.
  MaskJudgement own_mask_judgement = MaskJudgement::kJudged;
};

/// What tracking is told about a frame's mask: its own mask judged it as that mask says; a
/// carried mask or none leaves the safe start on (kUnjudged); without masks expected at all
/// (use_mask false, mask source none) kUnknown.
inline MaskJudgement liveJudgement(MaskSource source, bool expect_masks, MaskJudgement own_mask_judgement) {
  if (!expect_masks) return MaskJudgement::kUnknown;
  return source == MaskSource::kMatched ? own_mask_judgement : MaskJudgement::kUnjudged;
}

/// Counters since construction.
struct LiveCounters {
  std::uint64_t frames_in = 0;         ///< frames added
  std::uint64_t frames_processed = 0;  ///< taken for preparation (then tracked, or failed: see frames_failed)
  std::uint64_t frames_dropped = 0;    ///< dropped while waiting (beyond max_pending_frames)
  std::uint64_t frames_discarded =
      0;  ///< forgotten by clearWaiting() or stop() before preparation, or added after stop() or finish()
  std::uint64_t frames_failed = 0;        ///< processed, but their conversion, tracking or sink threw
  std::uint64_t frames_matched = 0;       ///< released with their own mask
  std::uint64_t frames_mask_carried = 0;  ///< released with a carried mask
  std::uint64_t frames_without_mask = 0;  ///< released with none although masks were expected
  std::uint64_t late_masks = 0;           ///< masks that came after their frame had gone on
  std::uint64_t frames_caught_up = 0;     ///< tracked in catch-up mode
};

/// Rolling figures over the newest frames.
struct LiveStatistics {
  double tracking_p50_ms = 0.0;  ///< median work per frame (features + tracking) [ms]
  double tracking_p95_ms = 0.0;  ///< 95th percentile of the same [ms]
  double input_rate_hz = 0.0;    ///< frames added per second over the last 5 s [Hz]
};

/// This frame's path through the live tracker.
struct LiveFrameFigures {
  double mask_wait_ms = 0.0;  ///< from addFrame to its release by the pairer [ms]
  double tracking_ms = 0.0;   ///< its features (on the preparing thread) + tracking [ms]
  int frames_waiting = 0;     ///< frames queued behind it when it was tracked
  bool caught_up = false;     ///< tracked in catch-up mode
};

/// A frame that could not go through: dropped, the next frames go on.
struct LiveFailure {
  Timestamp stamp_ns = 0;
  std::string message;       ///< what failed and why, for a log
  std::exception_ptr error;  ///< the exception itself (a caller may rethrow it)
};

/// `Input`: what the caller adds per frame (moved through; converted once on the preparing
/// thread); `Mask`: what it adds per mask (copied when carried to several frames: cheap to copy).
template <class Input, class Mask>
class LiveTracker {
 public:
  using Pairer = MaskPairer<Input, Mask>;
  using Ready = typename Pairer::Ready;  ///< stamp, input, mask, source, wait

  /// A tracked frame, handed to the sink.
  struct Tracked {
    Ready ready;            ///< the frame as paired
    TrackingOutput output;  ///< output.dropped: the stage rejected its stamp (nothing to publish)
    LiveFrameFigures live;
  };

  /// The caller's side. `convert` runs on the preparing thread and throws on an input it cannot
  /// convert; `sink` runs on the tracking thread, once per tracked frame, in stamp order;
  /// `failure` (optional) on the thread where a frame failed. None may call stop() or finish().
  struct Callbacks {
    std::function<LiveFrame(const Ready&)> convert;
    std::function<void(Tracked&)> sink;
    std::function<void(const LiveFailure&)> failure;
  };

  /// Starts both threads. `stage` must outlive the tracker; its options make the preparer's.
  /// `expect_masks` false: frames go on at once without a mask. Throws std::invalid_argument on
  /// bad `pairing` options or missing callbacks.
  LiveTracker(TrackingStage& stage, const MaskPairingOptions& pairing, bool expect_masks, Callbacks callbacks)
      : stage_(stage),
        expect_masks_(expect_masks),
        callbacks_(std::move(callbacks)),
        preparer_(stage.options()),
        pairer_(pairing, expect_masks) {
    if (!callbacks_.convert || !callbacks_.sink)
      throw std::invalid_argument("LiveTracker: convert and sink are required");
    preparing_thread_ = std::thread([this] { prepareLoop(); });
    tracking_thread_ = std::thread([this] { trackLoop(); });
  }

  LiveTracker(const LiveTracker&) = delete;
  LiveTracker& operator=(const LiveTracker&) = delete;
  ~LiveTracker() { stop(); }

  /// A new frame, now. Returns the frame dropped to make room (MaskPairer::addFrame), if any.
  /// After stop() or finish() the frame is not taken (counted as discarded).
  std::optional<Input> addFrame(Timestamp stamp_ns, Input frame) {
    std::optional<Input> dropped;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      const double now_s = steadyClockSeconds();
      input_rate_.add(now_s);
      if (closing_ != Closing::kOpen) {
        ++refused_;
        return dropped;
      }
      dropped = pairer_.addFrame(stamp_ns, std::move(frame), now_s);
    }
    wake_.notify_one();
    return dropped;
  }

  /// The mask of the frame stamped `stamp_ns`.
  void addMask(Timestamp stamp_ns, Mask mask) {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      pairer_.addMask(stamp_ns, std::move(mask));
    }
    wake_.notify_one();
  }

  /// No more input: the frames still waiting go on as their masks come or their waits end
  /// (at most max_wait_s), and every one reaches the sink before this returns. Then stopped.
  void finish() { close(Closing::kFinish); }

  /// Stops now: the frames not yet being prepared are discarded (counted); the one being
  /// prepared and the one prepared are tracked. Joins the preparing, then the tracking thread.
  /// Idempotent.
  void stop() { close(Closing::kStop); }

  /// Forgets the frames waiting (counted as discarded) and the masks, e.g. after a reset.
  void clearWaiting() {
    std::lock_guard<std::mutex> lock(mutex_);
    discarded_ += pairer_.pending();
    pairer_.clear();
  }

  LiveCounters counters() const {
    std::lock_guard<std::mutex> lock(mutex_);
    const MaskPairingStats& s = pairer_.stats();
    LiveCounters c;
    c.frames_in = s.frames_in + refused_;
    c.frames_processed = processed_;
    c.frames_dropped = s.dropped;
    c.frames_discarded = discarded_ + refused_;
    c.frames_failed = failed_;
    c.frames_matched = s.matched;
    c.frames_mask_carried = s.carried;
    c.frames_without_mask = expect_masks_ ? s.without_mask : 0;
    c.late_masks = s.late_masks;
    c.frames_caught_up = caught_up_;
    return c;
  }

  LiveStatistics statistics() const {
    std::lock_guard<std::mutex> lock(mutex_);
    LiveStatistics s;
    s.tracking_p50_ms = tracking_ms_.percentile(0.5);
    s.tracking_p95_ms = tracking_ms_.percentile(0.95);
    s.input_rate_hz = input_rate_.rateHz(steadyClockSeconds());
    return s;
  }

  /// Frames waiting for their masks (in the pairer) now.
  std::size_t framesWaiting() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return pairer_.pending();
  }

  const MaskPairingOptions& pairingOptions() const { return pairer_.options(); }
  bool expectsMasks() const { return expect_masks_; }

 private:
  enum class Closing { kOpen, kFinish, kStop };

  /// A paired frame, converted, with its features: what the tracking thread takes.
  struct Prepared {
    Ready ready;
    LiveFrame frame;
    PreparedFeatures features;
  };

  void close(Closing how) {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      if (closing_ == Closing::kOpen || how == Closing::kStop) closing_ = how;
    }
    wake_.notify_all();
    std::lock_guard<std::mutex> join_lock(join_mutex_);
    if (preparing_thread_.joinable()) preparing_thread_.join();  // closes the hand-over as it ends
    if (tracking_thread_.joinable()) tracking_thread_.join();
  }

  void prepareLoop() {
    nameCurrentThread("dypho_features");
    std::unique_lock<std::mutex> lock(mutex_);
    while (true) {
      if (closing_ == Closing::kStop) {
        discarded_ += pairer_.pending();
        pairer_.clear();
        break;
      }
      std::vector<Ready> ready = pairer_.takeReady(steadyClockSeconds());
      if (ready.empty()) {
        if (closing_ == Closing::kFinish && pairer_.pending() == 0) break;
        const std::optional<double> wait_s = pairer_.secondsUntilDeadline(steadyClockSeconds());
        if (wait_s) {
          wake_.wait_for(lock, std::chrono::duration<double>(*wait_s + 1e-4));
        } else {
          wake_.wait(lock);
        }
        continue;
      }
      taken_ = ready.size();
      for (Ready& r : ready) {
        --taken_;
        if (closing_ == Closing::kStop) {
          ++discarded_;
          continue;
        }
        ++processed_;
        lock.unlock();
        prepare(std::move(r));
        lock.lock();
      }
    }
    lock.unlock();
    prepared_.close();  // the tracking thread tracks what is prepared, then ends
  }

  void prepare(Ready ready) {
    Prepared item;
    try {
      item.frame = callbacks_.convert(ready);
      const cv::Mat& mask = item.frame.mask;
      const cv::Mat& image = item.frame.frame.bgr;
      if (!mask.empty() && mask.size() != image.size()) {
        throw std::invalid_argument("mask is " + std::to_string(mask.cols) + "x" + std::to_string(mask.rows) +
                                    " but the image is " + std::to_string(image.cols) + "x" +
                                    std::to_string(image.rows));
      }
      item.features = preparer_.prepare(item.frame.frame, mask);
    } catch (const std::exception& e) {
      fail(ready.stamp_ns, std::string("dropping frame: ") + e.what());
      return;
    }
    item.ready = std::move(ready);
    prepared_.pushWhenRoom(std::move(item));  // always taken: the hand-over closes after this thread ends
  }

  void trackLoop() {
    nameCurrentThread("dypho_tracking");
    while (std::optional<Prepared> item = prepared_.pop()) track(*item);
  }

  void track(Prepared& item) {
    Tracked tracked;
    const double t0 = steadyClockSeconds();
    // Frames queued behind this one: waiting for their mask or for the preparing thread, or prepared.
    int frames_waiting = static_cast<int>(prepared_.size());
    {
      std::lock_guard<std::mutex> lock(mutex_);
      frames_waiting += static_cast<int>(pairer_.pending() + taken_);
    }
    try {
      const MaskJudgement judgement = liveJudgement(item.ready.source, expect_masks_, item.frame.own_mask_judgement);
      tracked.output = stage_.process(item.frame.frame, item.frame.mask, judgement, &item.features, frames_waiting);
    } catch (const std::exception& e) {
      fail(item.ready.stamp_ns, std::string("tracking failed on this frame, dropped: ") + e.what());
      return;
    }
    tracked.live.tracking_ms = (steadyClockSeconds() - t0) * 1e3 + item.features.ms;
    tracked.live.mask_wait_ms = item.ready.waited_s * 1e3;
    tracked.live.frames_waiting = frames_waiting;
    tracked.live.caught_up = tracked.output.result.caught_up;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      if (!tracked.output.dropped) tracking_ms_.add(tracked.live.tracking_ms);
      if (tracked.live.caught_up) ++caught_up_;
    }
    tracked.ready = std::move(item.ready);
    try {
      callbacks_.sink(tracked);
    } catch (const std::exception& e) {
      fail(tracked.ready.stamp_ns, std::string("handing on a tracked frame failed: ") + e.what());
    }
  }

  /// Called inside a catch block: reports the exception being handled.
  void fail(Timestamp stamp_ns, std::string message) {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      ++failed_;
    }
    if (callbacks_.failure) callbacks_.failure(LiveFailure{stamp_ns, std::move(message), std::current_exception()});
  }

  TrackingStage& stage_;
  const bool expect_masks_;
  const Callbacks callbacks_;
  FeaturePreparer preparer_;  ///< the preparing thread's

  mutable std::mutex mutex_;      ///< guards the pairer, the counters, the figures and closing_
  std::condition_variable wake_;  ///< a frame, a mask or a close for the preparing thread
  Pairer pairer_;
  Closing closing_ = Closing::kOpen;
  std::uint64_t processed_ = 0, discarded_ = 0, refused_ = 0, failed_ = 0, caught_up_ = 0;
  std::size_t taken_ = 0;  ///< frames released by the pairer that the preparing thread has not started yet
  RollingSamples tracking_ms_;
  mutable EventRate input_rate_;

  BoundedHandOver<Prepared> prepared_{1};  ///< preparing -> tracking: one frame waits at most
  std::mutex join_mutex_;                  ///< one closer joins
  std::thread preparing_thread_;
  std::thread tracking_thread_;
};

}  // namespace dypho::tracking
