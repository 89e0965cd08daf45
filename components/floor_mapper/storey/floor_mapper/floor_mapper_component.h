// floor_mapper component: subscribes a robot's scan and odometry (best effort) and its
// floor events (reliable), runs mapping::FloorSessions (one floor graph per floor,
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

#include "nav_msgs/msg/OdometryPubSubTypes.h"
#include "sensor_msgs/msg/LaserScanPubSubTypes.h"
#include "storey/mapping/floor_sessions.h"
#include "storey/runtime/component.h"
#include "storey_msgs/msg/FloorEventPubSubTypes.h"
#include "storey_msgs/msg/FloorGraphUpdatePubSubTypes.h"
#include "tf2_msgs/msg/TFMessagePubSubTypes.h"

namespace storey::floor_mapper {

struct FloorMapperComponentOptions {
  std::string robot;                               // reads /<robot>/scan, /<robot>/odom
  std::string events_topic = "floor_events";       // under the robot's namespace
  std::string floor_graph_topic = "storey/floor_graphs";
  int initial_floor = 0;
  double initial_height = 0.0;
  double max_odometry_gap = 0.5;  // s: a scan needs odometry this close to its stamp
  mapping::FloorSlamOptions slam;
};
// Reads the keys above and `slam` (see mapping::readFloorSlamOptions); calls finish().
FloorMapperComponentOptions readFloorMapperComponentOptions(const common::ConfigNode& node);

class FloorMapperComponent : public runtime::Component {
 public:
  FloorMapperComponent(runtime::Context& context, const common::ConfigNode& parameters,
                       std::string name);

  std::uint64_t updatesPublished() const;
  std::size_t nodeCount() const;  // over all floors
  // Optimises the current floor graph once more and publishes what is new.
  bool flush(double timeout_s) override;
  const FloorMapperComponentOptions& options() const { return options_; }

 protected:
  void onConfigure() override;
  void onCleanup() override;

 private:
  void onScan(const sensor_msgs::msg::LaserScan& message);
  void onOdometry(const nav_msgs::msg::Odometry& message);
  void onFloorEvent(const storey_msgs::msg::FloorEvent& message);
  void onTfStatic(const tf2_msgs::msg::TFMessage& message);
  void publishUpdates();  // with mutex_ held
  void processPendingScans(bool all);  // with mutex_ held
  void addScan(const sensor::LaserScan& scan);  // with mutex_ held

  FloorMapperComponentOptions options_;
  mutable std::mutex mutex_;
  std::unique_ptr<mapping::FloorSessions> sessions_;
  std::deque<sensor::OdometrySample> odometry_;
  std::deque<sensor::LaserScan> pending_scans_;  // waiting for odometry past their stamps
  std::map<std::string, geometry::Pose2> laser_offsets_;  // laser frame -> mounting on base_link
  std::map<int, std::uint32_t> sequence_;  // per floor graph
  std::shared_ptr<runtime::Publisher<storey_msgs::msg::FloorGraphUpdate,
                                     storey_msgs::msg::FloorGraphUpdatePubSubType>>
      publisher_;
  std::uint64_t published_ = 0;
};

}  // namespace storey::floor_mapper
