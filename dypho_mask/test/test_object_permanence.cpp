// ObjectPermanence: a region the mask called dynamic stays while it is the same surface, in front
// of the background, and seen move recently; it follows the flow.
#include <gtest/gtest.h>

#include <stdexcept>

#include <opencv2/core.hpp>

#include "dypho/mask/object_permanence.h"

using namespace dypho::mask;

namespace DYPHO_UNITY_ID {

const cv::Size kSize(80, 60);
const cv::Rect kPerson(20, 10, 16, 40);

cv::Mat depthWithPerson(const cv::Rect& person, float person_m = 1.5f, float wall_m = 3.0f) {
  cv::Mat d(kSize, CV_32FC1, cv::Scalar(wall_m));
  d(person).setTo(person_m);
  return d;
}

cv::Mat maskOf(const cv::Rect& r) {
  cv::Mat m = cv::Mat::zeros(kSize, CV_8UC1);
  m(r).setTo(255);
  return m;
}

/// Backward flow (current pixel -> previous position) of a uniform shift, at half the resolution
/// [px of that resolution]: content that moved by +dx full px reads the previous image at x - dx.
cv::Mat shiftFlowHalfRes(float dx_full_px) {
  return cv::Mat(kSize.height / 2, kSize.width / 2, CV_32FC2, cv::Scalar(-dx_full_px / 2.f, 0.f));
}

int count(const cv::Mat& m, const cv::Rect& r) { return cv::countNonZero(m(r)); }

PermanenceSettings settings(int frames) {
  PermanenceSettings s;
  s.max_quiet_frames = frames;
  return s;
}

TEST(ObjectPermanence, KeepsAQuietRegionForMaxQuietFramesThenDropsIt) {
  ObjectPermanence p(settings(3));
  const cv::Mat depth = depthWithPerson(kPerson);
  const cv::Mat flow = shiftFlowHalfRes(0.f);
  cv::Mat kept;
  p.carry(flow, depth, cv::Mat(), kept);
  EXPECT_EQ(cv::countNonZero(kept), 0) << "nothing to carry before the first remember()";
  p.remember(maskOf(kPerson), maskOf(kPerson), depth);  // found moving on this frame
  for (int quiet = 1; quiet <= 3; ++quiet) {
    p.carry(flow, depth, cv::Mat(), kept);
    EXPECT_EQ(count(kept, kPerson), kPerson.area()) << "quiet frame " << quiet;
    EXPECT_EQ(cv::countNonZero(kept), kPerson.area()) << "nothing outside the region";
    p.remember(kept, cv::Mat::zeros(kSize, CV_8UC1), depth);  // no fresh evidence
  }
  p.carry(flow, depth, cv::Mat(), kept);
  EXPECT_EQ(cv::countNonZero(kept), 0) << "quiet for more than max_quiet_frames";
}

TEST(ObjectPermanence, EvidenceAnywhereOnTheRegionRestartsItsCount) {
  ObjectPermanence p(settings(2));
  const cv::Mat depth = depthWithPerson(kPerson);
  const cv::Mat flow = shiftFlowHalfRes(0.f);
  cv::Mat kept;
  p.carry(flow, depth, cv::Mat(), kept);
  p.remember(maskOf(kPerson), maskOf(kPerson), depth);
  const cv::Rect outline(kPerson.x, kPerson.y, 2, kPerson.height);  // the flow sees only an edge
  for (int frame = 0; frame < 6; ++frame) {
    p.carry(flow, depth, cv::Mat(), kept);
    ASSERT_EQ(count(kept, kPerson), kPerson.area()) << "frame " << frame;
    p.remember(kept, maskOf(outline), depth);
  }
}

TEST(ObjectPermanence, FollowsTheFlow) {
  ObjectPermanence p(settings(30));
  p.remember(maskOf(kPerson), maskOf(kPerson), depthWithPerson(kPerson));
  const cv::Rect moved = kPerson + cv::Point(8, 0);
  cv::Mat kept;
  p.carry(shiftFlowHalfRes(8.f), depthWithPerson(moved), cv::Mat(), kept);
  EXPECT_EQ(count(kept, moved), moved.area());
  EXPECT_EQ(cv::countNonZero(kept), moved.area()) << "the uncovered wall is not kept";
}

TEST(ObjectPermanence, ADepthJumpOrTheBackgroundReleasesAPixel) {
  ObjectPermanence p(settings(30));
  p.remember(maskOf(kPerson), maskOf(kPerson), depthWithPerson(kPerson));
  cv::Mat kept;
  // The person left: the wall behind (3 m) is 1.5 m farther than the carried surface.
  p.carry(shiftFlowHalfRes(0.f), depthWithPerson(kPerson, 3.0f), cv::Mat(), kept);
  EXPECT_EQ(cv::countNonZero(kept), 0);

  ObjectPermanence q(settings(30));
  q.remember(maskOf(kPerson), maskOf(kPerson), depthWithPerson(kPerson));
  // Same depth, but the background has learnt this surface at 1.6 m (depth 1.5 >= 1.6 - 0.2).
  cv::Mat background(kSize, CV_32FC1, cv::Scalar(1.6f));
  q.carry(shiftFlowHalfRes(0.f), depthWithPerson(kPerson), background, kept);
  EXPECT_EQ(cv::countNonZero(kept), 0);
  // A background 3 m behind does not explain the person; no background value (0) neither.
  background.setTo(3.0f);
  background(cv::Rect(kPerson.x, kPerson.y, kPerson.width, 10)).setTo(0.f);
  q.carry(shiftFlowHalfRes(0.f), depthWithPerson(kPerson), background, kept);
  EXPECT_EQ(count(kept, kPerson), kPerson.area());
}

TEST(ObjectPermanence, ASurfaceThatStandsInFrontOfNothingIsDropped) {
  // A patch of wall the mask once took in, where the background model has no value (never seen):
  // nothing around it is farther, so it is not kept; a person in the same place is.
  const cv::Mat unknown_background = cv::Mat::zeros(kSize, CV_32FC1);
  const cv::Mat wall = depthWithPerson(kPerson, 3.0f);
  cv::Mat kept;
  ObjectPermanence p(settings(30));
  p.remember(maskOf(kPerson), maskOf(kPerson), wall);
  p.carry(shiftFlowHalfRes(0.f), wall, unknown_background, kept);
  EXPECT_EQ(cv::countNonZero(kept), 0);

  ObjectPermanence q(settings(30));
  const cv::Mat person = depthWithPerson(kPerson);
  q.remember(maskOf(kPerson), maskOf(kPerson), person);
  q.carry(shiftFlowHalfRes(0.f), person, unknown_background, kept);
  EXPECT_EQ(count(kept, kPerson), kPerson.area()) << "the wall around the person is 1.5 m farther";

  // Where the background has values behind the patch, they speak for it (it stands 1 m in front).
  cv::Mat background(kSize, CV_32FC1, cv::Scalar(4.0f));
  ObjectPermanence r(settings(30));
  r.remember(maskOf(kPerson), maskOf(kPerson), wall);
  r.carry(shiftFlowHalfRes(0.f), wall, background, kept);
  EXPECT_EQ(count(kept, kPerson), kPerson.area());

  // With the test off (min_farther_outline_share 0) the patch stays.
  PermanenceSettings off = settings(30);
  off.min_farther_outline_share = 0.0;
  ObjectPermanence o(off);
  o.remember(maskOf(kPerson), maskOf(kPerson), wall);
  o.carry(shiftFlowHalfRes(0.f), wall, unknown_background, kept);
  EXPECT_EQ(count(kept, kPerson), kPerson.area());
}

TEST(ObjectPermanence, NoFlowNoDepthOrResetKeepNothing) {
  ObjectPermanence p(settings(30));
  const cv::Mat depth = depthWithPerson(kPerson);
  p.remember(maskOf(kPerson), maskOf(kPerson), depth);
  cv::Mat kept;
  p.carry(cv::Mat(), depth, cv::Mat(), kept);
  EXPECT_EQ(cv::countNonZero(kept), 0) << "no flow";
  cv::Mat holes = depth.clone();
  holes(kPerson).setTo(0.f);
  p.carry(shiftFlowHalfRes(0.f), holes, cv::Mat(), kept);
  EXPECT_EQ(cv::countNonZero(kept), 0) << "no depth";
  p.reset();
  p.carry(shiftFlowHalfRes(0.f), depth, cv::Mat(), kept);
  EXPECT_EQ(cv::countNonZero(kept), 0) << "after reset()";
  cv::Mat other(kSize.height + 2, kSize.width, CV_32FC1, cv::Scalar(1.5f));
  p.remember(maskOf(kPerson), maskOf(kPerson), depth);
  p.carry(shiftFlowHalfRes(0.f), other, cv::Mat(), kept);
  EXPECT_EQ(kept.size(), other.size());
  EXPECT_EQ(cv::countNonZero(kept), 0) << "size change";
}

TEST(ObjectPermanence, BadSettingsAreRejected) {
  EXPECT_THROW(ObjectPermanence(settings(0)), std::invalid_argument);
  PermanenceSettings s;
  s.max_depth_change_m = 0.0;
  EXPECT_THROW((ObjectPermanence(s)), std::invalid_argument);
  PermanenceSettings share;
  share.min_farther_outline_share = 1.5;
  EXPECT_THROW((ObjectPermanence(share)), std::invalid_argument);
  share.min_farther_outline_share = 0.1;
  share.min_background_share = -0.1;
  EXPECT_THROW((ObjectPermanence(share)), std::invalid_argument);
}  // namespace DYPHO_UNITY_ID
}  // namespace DYPHO_UNITY_ID
