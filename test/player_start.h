#pragma once
/// \file player_start.h
/// Starting a rostest's bag only once the graph is up. rosbag's --wait-for-subscribers waits for
/// one subscriber per topic, and several nodelets (and the test node) subscribe to the camera
/// topics: a nodelet that loads later (cold disk cache, slow machine) would miss the first frames.
/// The launch file starts the player with --pause; the test node resumes it here.
///
/// The bag itself is read once before the player resumes: the test is about the graph at the
/// camera's rate, and a camera does not read a disk. A machine that paged the file out since it
/// was written (the project's development VM pages out files idle for a minute) made the player
/// read it from disk while the nodelets paged their own code in: measured after five minutes of
/// other work, frames reached the graph up to 0.5 s late and in a burst.

#include <fstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <ros/master.h>
#include <ros/ros.h>
#include <std_srvs/SetBool.h>

namespace dypho::test {

/// Reads the file at `path` once (into the page cache); false when it cannot be read.
inline bool readWholeFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return false;
  std::vector<char> block(4 << 20);
  while (in.read(block.data(), static_cast<std::streamsize>(block.size())) || in.gcount() > 0) {
  }
  return in.eof();
}

/// Waits until every topic of `outputs` has a publisher (each nodelet advertises its outputs just
/// before it subscribes to its inputs), reads `bag` once (empty: not), then `settle_s` for the
/// player's connections to the new subscriptions, then resumes the player through its
/// ~pause_playback service.
inline ::testing::AssertionResult resumePlayerOnceAdvertised(const std::vector<std::string>& outputs,
                                                             const std::string& bag,
                                                             const std::string& player = "/player",
                                                             double timeout_s = 60.0, double settle_s = 1.0) {
  const ros::WallTime start = ros::WallTime::now();
  for (;;) {
    ros::master::V_TopicInfo topics;
    std::size_t advertised = 0;
    if (ros::master::getTopics(topics)) {
      for (const std::string& wanted : outputs) {
        for (const ros::master::TopicInfo& t : topics) {
          if (t.name == wanted) {
            ++advertised;
            break;
          }
        }
      }
    }
    if (advertised == outputs.size()) break;
    if ((ros::WallTime::now() - start).toSec() > timeout_s) {
      return ::testing::AssertionFailure()
             << advertised << " of " << outputs.size() << " graph outputs advertised after " << timeout_s
             << " s: did every nodelet load?";
    }
    ros::WallDuration(0.1).sleep();
  }
  if (!bag.empty() && !readWholeFile(bag)) return ::testing::AssertionFailure() << "cannot read the bag " << bag;
  ros::WallDuration(settle_s).sleep();
  const std::string service = player + "/pause_playback";
  if (!ros::service::waitForService(service, static_cast<int>(timeout_s * 1000))) {
    return ::testing::AssertionFailure() << "no " << service << ": start the player with --pause";
  }
  std_srvs::SetBool resume;
  resume.request.data = false;
  if (!ros::service::call(service, resume)) return ::testing::AssertionFailure() << service << " failed";
  if (!resume.response.success) {
    return ::testing::AssertionFailure() << service << ": " << resume.response.message
                                         << " (was the player started with --pause?)";
  }
  return ::testing::AssertionSuccess();
}

}  // namespace dypho::test
