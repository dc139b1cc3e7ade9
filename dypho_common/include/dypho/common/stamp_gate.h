#pragma once
/// \file stamp_gate.h
/// One rule for frames whose stamp is not after the newest accepted one, shared by the mask and
/// tracking stages so that both answer every frame the same way:
///  - the same stamp again (a repeated message), or a stamp at most `restart_after_s` earlier (a
///    frame delivered late, out of order): the frame is dropped and counted; nothing restarts;
///  - a stamp more than `restart_after_s` earlier (a looped bag, a camera driver or clock that
///    restarted): a new run begins; the stage restarts and takes the frame.
/// Not thread-safe (each stage calls it under its own lock).

#include <cstddef>
#include <cstdint>
#include <sstream>
#include <string>

#include "dypho/common/types.h"

namespace dypho {

/// A frame's stamp relative to the newest accepted one.
enum class StampOrder {
  kNext,        ///< after the newest (or the first frame): take it
  kRepeated,    ///< equal to the newest: drop it
  kLate,        ///< earlier, by at most restart_after_s: drop it
  kJumpedBack,  ///< earlier by more: restart, then take it
};

inline const char* toString(StampOrder order) {
  switch (order) {
    case StampOrder::kNext:
      return "next";
    case StampOrder::kRepeated:
      return "repeated stamp";
    case StampOrder::kLate:
      return "out of order";
    case StampOrder::kJumpedBack:
      return "time jumped backwards";
  }
  return "unknown";
}

class StampGate {
 public:
  /// A jump back of more than this restarts [s]; default 1.0 (as ConstantVelocityModel's gap: a
  /// late frame is at most a few frame intervals old, a looped bag goes back by its length).
  static constexpr double kDefaultRestartAfterS = 1.0;

  explicit StampGate(double restart_after_s = kDefaultRestartAfterS)
      : restart_after_s_(restart_after_s), restart_after_ns_(static_cast<Timestamp>(restart_after_s * 1e9)) {}

  /// Classifies `stamp_ns`; kNext and kJumpedBack make it the newest accepted stamp.
  StampOrder admit(Timestamp stamp_ns) {
    if (!has_newest_ || stamp_ns > newest_ns_) {
      accept(stamp_ns);
      return StampOrder::kNext;
    }
    if (stamp_ns == newest_ns_) {
      ++dropped_;
      return StampOrder::kRepeated;
    }
    // newest_ns_ - stamp_ns > 0 here; compared without overflow for any int64 pair.
    const std::uint64_t back_ns = static_cast<std::uint64_t>(newest_ns_) - static_cast<std::uint64_t>(stamp_ns);
    if (back_ns <= static_cast<std::uint64_t>(restart_after_ns_)) {
      ++dropped_;
      return StampOrder::kLate;
    }
    accept(stamp_ns);
    ++restarts_;
    return StampOrder::kJumpedBack;
  }

  /// What a user reads when a frame was dropped for `order` (kRepeated or kLate).
  std::string dropMessage(StampOrder order) const {
    std::ostringstream os;
    os << "frame dropped: " << toString(order) << " (its stamp is not after the previous frame's, and at most "
       << restart_after_s_ << " s before it; a larger jump back restarts)";
    return os.str();
  }

  void reset() {
    has_newest_ = false;
    newest_ns_ = 0;
  }
  /// Frames dropped as repeated or late since construction.
  std::size_t dropped() const { return dropped_; }
  /// Jumps back since construction.
  std::size_t restarts() const { return restarts_; }

 private:
  void accept(Timestamp stamp_ns) {
    has_newest_ = true;
    newest_ns_ = stamp_ns;
  }

  double restart_after_s_;
  Timestamp restart_after_ns_;
  bool has_newest_ = false;
  Timestamp newest_ns_ = 0;
  std::size_t dropped_ = 0, restarts_ = 0;
};

}  // namespace dypho
