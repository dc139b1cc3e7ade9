#pragma once
/// \file object_permanence.h
/// Keeps what the mask once called dynamic while it is still the same surface: a person whose
/// outline the flow stops seeing (walking sideways in horizontal stripes: the texture runs along
/// the motion, the aperture problem; standing still a moment) stays masked, and the background
/// model does not learn the person as background in the meantime.
///
/// Per frame, at the background model's resolution: the previous frame's dynamic pixels are
/// carried along the backward optical flow (each current pixel reads the previous frame where
/// its content came from). A carried pixel is kept when
///  - its current depth is within max_depth_change_m of the depth it had there (the same surface
///    moved; a pixel whose depth jumps shows what was behind: the person left it),
///  - the established background does not explain it (no background value, or the depth lies
///    more than sigma_m in front of it), and
///  - its surface was seen move not longer ago than max_quiet_frames: a surface's quiet count
///    restarts at 0 on every frame on which fresh evidence (flow, background consistency, the
///    network, tracking's moving points) touches it, and otherwise grows by one per frame
///    (surface: 4-connected dynamic pixels whose depths differ by at most 0.05 m + 3 % between
///    neighbours, the depth growth's rule), and
///  - its surface (now, among the kept pixels) stands in front of something: of the background
///    where the background has values behind it, else of its surroundings
///    (PermanenceSettings::min_farther_outline_share). A patch of wall or floor that the mask
///    once took in with a person, and that the background model has never seen, does not.
/// The quiet count bounds how long a wrong surface (flow noise on a static surface the background
/// has not seen) can last.

#include <vector>

#include <opencv2/core.hpp>

namespace dypho {
namespace mask {

/// Settings of `ObjectPermanence`.
struct PermanenceSettings {
  /// Frames a surface stays after the last fresh evidence touched it, >= 1.
  int max_quiet_frames = 30;
  /// Largest depth change of a carried pixel between two frames for it to be the same surface
  /// [m], > 0 (a person walks a few cm per frame; flow errors of a pixel at an outline read the
  /// neighbour's depth).
  double max_depth_change_m = 0.15;
  /// A carried pixel is explained by the background when the background depth is valid and the
  /// depth >= background - sigma_m [m], > 0 (the background model's sigma).
  double sigma_m = 0.2;
  /// A kept surface must stand in front of something: at least min_background_share of its
  /// pixels in front of a background value, or else at least min_farther_outline_share of its
  /// surroundings (the pixels 3 px beside each of its pixels that have depth and are neither kept
  /// nor found dynamic now) farther than it by more than sigma_m. A surface that does neither is
  /// dropped: a patch of wall or floor the background model has never seen, which the mask once
  /// took in with a person (a person stands in front of the floor and wall around them). Both in
  /// [0, 1]; min_farther_outline_share 0 = no surface is dropped.
  double min_background_share = 0.5;
  double min_farther_outline_share = 0.1;
};

/// Carries dynamic surfaces from frame to frame. Not thread-safe; one instance per image stream.
class ObjectPermanence {
 public:
  /// Validates `settings` (std::invalid_argument).
  explicit ObjectPermanence(const PermanenceSettings& settings);

  /// Writes `kept` (CV_8UC1 of `depth_m`'s size, 255 = the previous frame's dynamic pixel carried
  /// here and kept, see the file comment). `flow_cur_to_prev`: backward flow CV_32FC2 at any
  /// resolution [px of that resolution] (current pixel -> its position in the previous image);
  /// `depth_m` CV_32FC1 [m] (0 = none); `background_m` CV_32FC1 [m] of the same size (0 = none) or
  /// empty. `kept` is all 0 when there is no previous frame, no flow, or a size change.
  void carry(const cv::Mat& flow_cur_to_prev, const cv::Mat& depth_m, const cv::Mat& background_m, cv::Mat& kept,
             const cv::Mat& found_now = cv::Mat());

  /// Remembers this frame's final dynamic pixels `dynamic` (CV_8UC1, non-zero = dynamic, the size
  /// of the last carry()'s depth) with their depth, and which of them fresh evidence found
  /// (`evidence`, CV_8UC1, same size, non-zero = found this frame). A surface touching evidence
  /// restarts its quiet count; a surface made only of kept pixels (and what grew from them)
  /// continues theirs.
  void remember(const cv::Mat& dynamic, const cv::Mat& evidence, const cv::Mat& depth_m);

  /// Forgets the previous frame: the next carry() keeps nothing.
  void reset();

 private:
  /// Drops the surfaces of `kept` (labelled at `depth_m`) that stand in front of nothing
  /// (PermanenceSettings::min_farther_outline_share).
  void dropSurfacesInFrontOfNothing(const cv::Mat& depth_m, const cv::Mat& background_m, const cv::Mat& found_now,
                                    cv::Mat& kept);

  PermanenceSettings settings_;
  cv::Mat mask_;        ///< previous frame's dynamic pixels (CV_8UC1)
  cv::Mat depth_;       ///< previous frame's depth [m]
  cv::Mat quiet_;       ///< previous frame's quiet count per pixel (CV_16UC1)
  cv::Mat map_;         ///< previous-frame position of each current pixel (CV_32FC2)
  cv::Mat kept_;        ///< last carry()'s result
  cv::Mat kept_quiet_;  ///< carried quiet count at the kept pixels (CV_16UC1)
  cv::Mat carried_mask_, carried_depth_, labels_;
  std::vector<int> queue_;  ///< flood-fill queue of the surface labelling
};

}  // namespace mask
}  // namespace dypho
