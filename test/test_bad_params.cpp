/// rostest node for bad_params.test: loads each nodelet into a running manager with one bad
/// private parameter (unknown key, out-of-range value, wrong type, missing camera file) and
/// checks that the nodelet logs a FATAL error naming the parameter and stays idle (advertises
/// nothing), and that the manager goes on: it then loads a nodelet with good parameters, which
/// starts.

#include <mutex>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nodelet/NodeletLoad.h>
#include <nodelet/NodeletUnload.h>
#include <ros/master.h>
#include <ros/ros.h>
#include <rosgraph_msgs/Log.h>

namespace DYPHO_UNITY_ID {

struct LogLines {
  std::mutex mutex;
  std::vector<std::string> errors;  ///< FATAL lines of every node
  bool mentions(const std::string& a, const std::string& b) {
    std::lock_guard<std::mutex> lock(mutex);
    for (const std::string& line : errors)
      if (line.find(a) != std::string::npos && line.find(b) != std::string::npos) return true;
    return false;
  }
};

/// Topics published under `prefix` (e.g. "/bad/").
std::vector<std::string> topicsUnder(const std::string& prefix) {
  ros::master::V_TopicInfo topics;
  std::vector<std::string> found;
  if (!ros::master::getTopics(topics)) {
    ADD_FAILURE() << "could not list the master's topics";
    return found;
  }
  for (const auto& t : topics)
    if (t.name.rfind(prefix, 0) == 0) found.push_back(t.name);
  return found;
}

bool load(const std::string& name, const std::string& type) {
  nodelet::NodeletLoad srv;
  srv.request.name = name;
  srv.request.type = type;
  if (!ros::service::call("/params_manager/load_nodelet", srv)) {
    ADD_FAILURE() << "the manager's load_nodelet service did not answer for " << name;
    return false;
  }
  return srv.response.success;
}

/// Waits up to 10 s for an error line containing both strings (rosout delivers asynchronously).
bool waitForError(LogLines& log, const std::string& a, const std::string& b) {
  const ros::WallTime start = ros::WallTime::now();
  while ((ros::WallTime::now() - start).toSec() < 10.0) {
    if (log.mentions(a, b)) return true;
    ros::WallDuration(0.1).sleep();
  }
  return false;
}

TEST(BadParams, EachBadParameterFailsTheLoadByNameAndTheManagerGoesOn) {
  ros::NodeHandle nh;
  LogLines log;
  auto sub = nh.subscribe<rosgraph_msgs::Log>("/rosout", 200, [&](const rosgraph_msgs::LogConstPtr& m) {
    if (m->level < rosgraph_msgs::Log::FATAL) return;
    std::lock_guard<std::mutex> lock(log.mutex);
    log.errors.push_back(m->name + ": " + m->msg);
  });
  ros::AsyncSpinner spinner(1);
  spinner.start();
  ASSERT_TRUE(ros::service::waitForService("/params_manager/load_nodelet", ros::Duration(30.0)));
  // The manager's log must reach us: wait until it is connected to /rosout's subscribers.
  ros::WallDuration(2.0).sleep();

  // Each nodelet is loaded (the manager never fails on it) but logs why it did not start.
  EXPECT_TRUE(load("/bad/tracking", "dypho_slam/TrackingNodelet"));
  EXPECT_TRUE(waitForError(log, "unknown private parameter", "fast_treshold"));
  EXPECT_TRUE(load("/bad/mask", "dypho_slam/DynamicMaskNodelet"));
  EXPECT_TRUE(waitForError(log, "not started", "flow_scale"));
  EXPECT_TRUE(load("/bad/mapping", "dypho_slam/GaussianMappingNodelet"));
  EXPECT_TRUE(waitForError(log, "iterations_per_keyframe", "wrong type"));
  EXPECT_TRUE(load("/bad/tracking_camera", "dypho_slam/TrackingNodelet"));
  EXPECT_TRUE(waitForError(log, "not started", "/nonexistent/dypho_camera.yaml"));
  // ... and stays idle: nothing of theirs is advertised.
  const std::vector<std::string> bad_topics = topicsUnder("/bad/");
  EXPECT_TRUE(bad_topics.empty()) << "a nodelet with a bad parameter advertised " << bad_topics.front();

  // The manager goes on and starts a nodelet whose parameters are right.
  EXPECT_TRUE(load("/good/tracking", "dypho_slam/TrackingNodelet"));
  bool advertised = false;
  for (int i = 0; i < 50 && !advertised; ++i, ros::WallDuration(0.1).sleep()) {
    for (const std::string& t : topicsUnder("/good/")) advertised = advertised || t == "/good/tracking_status";
  }
  EXPECT_TRUE(advertised) << "the good tracking nodelet did not start";
  nodelet::NodeletUnload unload;
  unload.request.name = "/good/tracking";
  EXPECT_TRUE(ros::service::call("/params_manager/unload_nodelet", unload) && unload.response.success);

  std::lock_guard<std::mutex> lock(log.mutex);
  for (const std::string& line : log.errors) std::cout << "  " << line << "\n";
}

}  // namespace DYPHO_UNITY_ID

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_bad_params");
  return RUN_ALL_TESTS();
}
