// Replays a recording over DDS: the sensor messages of a rosbag2 bag (every robot), or of
// a CARMEN log (one robot), published on <robot>/scan, odom, pressure, imu in recorded
// (laser mountings on tf_static, as ROS 2 does)
// order, at the recorded rate, a multiple of it, or as fast as possible.
#pragma once

#include <atomic>
#include <functional>
#include <map>
#include <vector>
#include <memory>
#include <string>

#include "storey/geometry/pose2.h"
#include "storey/runtime/context.h"
#include "storey/runtime/publisher.h"
#include "tf2_msgs/msg/TFMessagePubSubTypes.h"
#include "storey/runtime/sensor_bag.h"

namespace storey::tools {

struct ReplayOptions {
  double rate = 0.0;                 // 0: as fast as possible; 1: recorded rate; k: k times faster
  std::string log_robot = "robot";   // CARMEN logs carry no robot name
  std::string topic_prefix;          // prepended to every topic ("" -> "<robot>/scan")
  // The robots' sensor topic names (the components' scan_topic, odom_topic, imu_topic,
  // pressure_topic): which topics of a bag are read, and where they are published.
  runtime::SensorTopics topics;
  double settle_seconds = 0.3;       // wait after creating publishers, for discovery
  // At the end, wait this long at most for acknowledgments (and, with min_subscribers,
  // for that many subscribers on each scan topic again: one restarted mid-replay).
  double ack_seconds = 3.0;
  // > 0: before a robot's first message, wait until each of its topics has a subscriber
  // and its scan topic this many (e.g. detector + mapper), then settle_seconds; so a
  // deployment started beforehand misses nothing (throws after subscriber_timeout).
  int min_subscribers = 0;
  double subscriber_timeout = 60.0;
  // Called after each message is published (e.g. to wait until subscribers processed it).
  std::function<void()> after_each;
};

struct ReplaySummary {
  std::map<std::string, std::uint64_t> published;  // per topic
  std::uint64_t total = 0;
  double first_stamp = 0.0;  // earliest and latest sample stamps
  double last_stamp = 0.0;
  double wall_seconds = 0.0;
  std::uint64_t skipped = 0;       // records of other types, or unreadable
  std::uint64_t out_of_order = 0;  // stamps going backwards (published anyway)
  bool stopped = false;            // interrupted before the end
  // The damage that ended a bag's replay early (bag::BagError: a truncated or corrupt
  // file); "" when it ran to its end. What came before it was published.
  std::string cut_short;
  // Topics whose reliable subscribers did not all acknowledge every sample in time.
  std::vector<std::string> unacknowledged;
  std::string text() const;        // a readable summary
};

// A stream of sensor records from a bag folder or a CARMEN log (by what the path is).
class SensorSource {
 public:
  virtual ~SensorSource() = default;
  virtual bool next(runtime::SensorRecord& record) = 0;
  virtual std::uint64_t skipped() const = 0;
  virtual std::uint64_t outOfOrder() const = 0;
  // What was skipped and why, for a warning ("" when nothing was, or no more is known).
  virtual std::string skippedNote() const { return ""; }
  // Best-effort estimate of the number of records (for progress), 0 when unknown.
  virtual std::uint64_t expectedCount() const { return 0; }
};
// Throws std::runtime_error naming the path when it is neither a bag nor a log.
std::unique_ptr<SensorSource> openSensorSource(const std::string& path, const ReplayOptions& options);
bool isCarmenLog(const std::string& path);
bool isBag(const std::string& path);

class SensorReplayer {
 public:
  SensorReplayer(runtime::Context& context, const ReplayOptions& options);
  ~SensorReplayer();
  // Publishes one record on its robot's topic (publishers are created on first use).
  void publish(const runtime::SensorRecord& record);
  // Replays a whole source; `stop` (may be null) interrupts; `progress` (may be empty) is
  // called now and then with (records done, expected or 0). A damaged bag ends the replay
  // at the damage (summary's cut_short) rather than throwing away what came before.
  ReplaySummary replay(SensorSource& source, const std::atomic<bool>* stop = nullptr,
                       const std::function<void(std::uint64_t, std::uint64_t)>& progress = {});

 private:
  struct Publishers;
  Publishers& publishersFor(const std::string& robot);
  void publishLaserOffset(const std::string& robot, const sensor::LaserScan& scan);
  runtime::Context& context_;
  ReplayOptions options_;
  std::map<std::string, std::unique_ptr<Publishers>> publishers_;
  std::map<std::string, geometry::Pose2> laser_offsets_;
  std::unique_ptr<runtime::Publisher<tf2_msgs::msg::TFMessage, tf2_msgs::msg::TFMessagePubSubType>> tf_static_;
};

}  // namespace storey::tools
