// floor_mapper component: subscribes a robot's scan and odometry (best effort) and its
// floor events (reliable), puts them in stamp order (mapping::InputSequencer: the same
// recording gives the same graphs however delivery interleaves the topics), runs
// mapping::FloorSessions (one floor graph per floor,
// resumed when the robot comes back), and publishes storey_msgs/FloorGraphUpdate on
// floor_graph_topic (reliable, transient local): new nodes with scans, new edges, and
// optimised poses. Parameters: config/floor_mapper.yaml. Data is processed only while
// active.
#pragma once

#include <deque>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "nav_msgs/msg/OdometryPubSubTypes.h"
#include "sensor_msgs/msg/LaserScanPubSubTypes.h"
#include "storey/common/shipped_config.h"
#include "storey/floor/floor_event.h"
#include "storey/geometry/frame_tree.h"
#include "storey/mapping/floor_sessions.h"
#include "storey/mapping/input_log.h"
#include "storey/mapping/input_sequencer.h"
#include "storey/runtime/component.h"
#include "storey/runtime/sensor_bag.h"
#include "storey_msgs/msg/FloorEventPubSubTypes.h"
#include "storey_msgs/msg/FloorGraphUpdatePubSubTypes.h"
#include "storey_msgs/msg/FloorIdentityPubSubTypes.h"
#include "tf2_msgs/msg/TFMessagePubSubTypes.h"

namespace storey::floor_mapper {

struct FloorMapperComponentOptions {
  std::string robot;  // topic namespace
  // Scan and odometry topics in (imu, pressure unused); relative or absolute.
  runtime::SensorTopics topics{shipped::floor_mapper::scan_topic,
                               shipped::floor_mapper::odom_topic};
  // under the robot's namespace
  std::string events_topic = shipped::floor_mapper::events_topic;
  std::string floor_graph_topic = shipped::floor_mapper::floor_graph_topic;
  int initial_floor = shipped::floor_mapper::initial_floor;
  double initial_height = shipped::floor_mapper::initial_height;
  // Floor-graph ids must be unique across the fleet (the graph server and the matcher key
  // graphs by id): this robot's are first_floor_graph_id, +1, ... (fewer than 1000); -1
  // derives the first from the robot's name (floorGraphIdBase).
  long first_floor_graph_id = shipped::floor_mapper::first_floor_graph_id;
  // max_odometry_gap, wait_for_floor_detector, max_floor_detector_lag (top-level keys).
  mapping::InputSequencerOptions input;
  // Input log (mapping::InputLog) replayed on start, so a restarted mapper resumes its
  // graphs exactly; empty: none (a restarted mapper would start afresh).
  std::string input_log = shipped::floor_mapper::input_log;
  mapping::FloorSlamOptions slam;
};
// Reads the keys above and `slam` (see mapping::readFloorSlamOptions); calls finish().
FloorMapperComponentOptions readFloorMapperComponentOptions(const common::ConfigNode& node);

// 1000 x (FNV-1a hash of the robot's name mod 2^20): distinct robots get distinct ranges
// of 1000 floor-graph ids with high probability (30 robots: 4 in 10 000 of a clash, which
// the graph server then rejects by name rather than merging two robots' graphs).
int floorGraphIdBase(const std::string& robot);

// What became of the scans a floor_mapper received.
struct ScanCounts {
  std::size_t received = 0;
  std::size_t without_odometry = 0;  // dropped: no odometry within max_odometry_gap
  std::size_t rejected = 0;          // refused by the front end (bad scan or stamp)
  std::size_t notMapped() const { return without_odometry + rejected; }
};

class FloorMapperComponent : public runtime::Component {
 public:
  FloorMapperComponent(runtime::Context& context, const common::ConfigNode& parameters,
                       std::string name);

  std::uint64_t updatesPublished() const;
  std::size_t nodeCount() const;  // over all floors
  ScanCounts scanCounts() const;
  // Optimises the current floor graph once more and publishes what is new.
  bool flush(double timeout_s) override;
  const FloorMapperComponentOptions& options() const { return options_; }

 protected:
  void onConfigure() override;
  void onActivate() override;
  void onDeactivate() override;
  void onCleanup() override;

 private:
  void onScan(const sensor_msgs::msg::LaserScan& message);
  void onOdometry(const nav_msgs::msg::Odometry& message);
  void onFloorEvent(const storey_msgs::msg::FloorEvent& message);
  void onTfStatic(const tf2_msgs::msg::TFMessage& message);
  void publishUpdates();  // with mutex_ held
  // In stamp order, from the sequencer, with mutex_ held.
  void addScan(const sensor::LaserScan& scan, const geometry::Pose2& odometry);
  void applyFloorEvent(const floor::FloorEvent& event);
  void passMountedScans(bool all);  // with mutex_ held
  std::vector<std::string> baseFrames() const;  // with mutex_ held

  FloorMapperComponentOptions options_;
  mutable std::mutex mutex_;
  std::unique_ptr<mapping::FloorSessions> sessions_;
  std::unique_ptr<mapping::InputSequencer> sequencer_;
  std::unique_ptr<mapping::InputLog> input_log_;
  // Scans (laser frame, scan) waiting for their laser's mounting from tf_static.
  std::deque<std::pair<std::string, sensor::LaserScan>> unmounted_;
  bool mounting_warned_ = false;
  geometry::FrameTree frames_;             // from tf_static
  std::string odometry_frame_;             // the odometry's child_frame_id, once one arrived
  std::map<int, std::uint32_t> sequence_;  // per floor graph
  std::shared_ptr<runtime::Publisher<storey_msgs::msg::FloorGraphUpdate,
                                     storey_msgs::msg::FloorGraphUpdatePubSubType>>
      publisher_;
  // Answers to the detector's unsure arrivals (<robot>/floor_identity).
  std::shared_ptr<runtime::Publisher<storey_msgs::msg::FloorIdentity,
                                     storey_msgs::msg::FloorIdentityPubSubType>>
      identity_publisher_;
  void publishIdentities();
  std::uint64_t published_ = 0;
  std::size_t scans_received_ = 0, scans_rejected_ = 0;
};

}  // namespace storey::floor_mapper
