// Core sensor samples of named robots <-> a rosbag2 bag with ROS 2 types, so ROS 2 can
// play what storey records and storey can replay ROS 2 recordings.
//
// Topics per robot: /<robot>/scan (sensor_msgs/msg/LaserScan), /<robot>/odom
// (nav_msgs/msg/Odometry), /<robot>/pressure (sensor_msgs/msg/FluidPressure),
// /<robot>/imu (sensor_msgs/msg/Imu). Frames: <robot>/laser, <robot>/odom,
// <robot>/base_link, <robot>/imu. A laser's mounting goes to /tf_static
// (tf2_msgs/msg/TFMessage, <robot>/base_link -> <robot>/laser), as in ROS 2.
// The bag timestamp of each message is its sample stamp.
#pragma once

#include <cstdint>
#include <map>
#include <mutex>
#include <optional>
#include <string>
#include <variant>
#include <vector>

#include "storey/bag/bag_reader.h"
#include "storey/bag/bag_writer.h"
#include "storey/geometry/pose2.h"
#include "storey/runtime/bag_cdr.h"
#include "storey/runtime/sensor_conversions.h"
#include "storey/runtime/sensor_topics.h"
#include "storey/sensor/laser_scan.h"

namespace storey::runtime {

inline constexpr const char* kLaserScanType = "sensor_msgs/msg/LaserScan";
inline constexpr const char* kOdometryType = "nav_msgs/msg/Odometry";
inline constexpr const char* kFluidPressureType = "sensor_msgs/msg/FluidPressure";
inline constexpr const char* kImuType = "sensor_msgs/msg/Imu";
inline constexpr const char* kTfMessageType = "tf2_msgs/msg/TFMessage";
inline constexpr const char* kTfStaticTopic = "/tf_static";
inline constexpr const char* kTfTopic = "/tf";

// A tf_static topic in any namespace: reliable and transient local, as tf2's static
// broadcaster offers it and its listener asks for it.
inline bool isTfStaticTopic(const std::string& name) {
  return name.substr(name.rfind('/') + 1) == "tf_static";
}

class SensorBagWriter {
 public:
  explicit SensorBagWriter(const std::string& folder, const bag::BagWriterOptions& options = {});
  ~SensorBagWriter();  // closes (errors logged)
  SensorBagWriter(const SensorBagWriter&) = delete;
  SensorBagWriter& operator=(const SensorBagWriter&) = delete;

  // Bad input (non-finite stamp, bad robot name) throws std::invalid_argument.
  void write(const std::string& robot, const sensor::LaserScan& scan);
  void write(const std::string& robot, const sensor::OdometrySample& odom);
  void write(const std::string& robot, const sensor::PressureSample& pressure);
  void write(const std::string& robot, const sensor::ImuSample& imu);

  // Any generated message (ground truth, storey_msgs...) on a topic of the caller's choice.
  template <typename T>
  void writeMessage(const std::string& topic, const std::string& ros_type, double stamp,
                    const T& message, bool reliable = true) {
    std::lock_guard<std::mutex> lock(mutex_);
    writeLocked(topic, ros_type, stamp, message, reliable);
  }

  void close();
  std::uint64_t messageCount() const { return bag_.messageCount(); }
  const std::string& folder() const { return bag_.folder(); }

 private:
  void declare(const std::string& topic, const std::string& type, bool reliable);
  // Declares the topic on first use (sensors best effort), then writes; with mutex_ held.
  template <typename Msg>
  void writeLocked(const std::string& topic, const std::string& type, double stamp, const Msg& msg,
                   bool reliable = false) {
    declare(topic, type, reliable);
    serializeCdrInto(msg, buffer_);
    bag_.write(topic, stampToNanoseconds(stamp), buffer_);
  }
  // `child` mounted at `pose` on `parent` on /tf_static, when new or changed; each message
  // holds every static transform so far, as tf2's static broadcaster sends them (a
  // listener that joins late keeps only the last message).
  void writeStatic(const std::string& parent, const std::string& child, const geometry::Pose2& pose,
                   double stamp);

  std::mutex mutex_;
  bag::BagWriter bag_;
  std::vector<std::uint8_t> buffer_;
  std::map<std::string, std::pair<std::string, geometry::Pose2>>
      static_frames_;  // child -> parent, pose
};

using SensorData = std::variant<sensor::LaserScan, sensor::OdometrySample, sensor::PressureSample,
                                sensor::ImuSample>;

struct SensorRecord {
  std::string robot;  // the topic's namespace without the leading '/'
  std::string topic;
  double stamp = 0.0;             // the sample's own (header) stamp
  std::int64_t bag_stamp_ns = 0;  // when the bag recorded it
  SensorData data;
};

struct SensorBagStats {
  std::uint64_t yielded = 0;
  std::uint64_t skipped = 0;  // messages on topics of other types (/tf_static and /tf excluded)
  std::uint64_t malformed = 0;     // messages that did not decode; skipped with a warning
  std::uint64_t out_of_order = 0;  // header stamp earlier than the previous on its topic
  std::vector<std::string> skipped_topics;
};

// Reads the sensor messages of every robot in a bag as one time-ordered stream (by bag
// timestamp). A sensor topic is a robot's when `topics` names it for its type (its robot
// as robotOfTopic says); sensor topics named otherwise are skipped and listed in
// stats().skipped_topics. Scan sensor offsets come from /tf_static when present (identity
// otherwise).
class SensorBagReader {
 public:
  explicit SensorBagReader(const std::string& path, const SensorTopics& topics = {});

  // Robots with at least one sensor topic, sorted.
  std::vector<std::string> robots() const;
  // Which sensors a robot's topics hold (by type).
  struct Sensors {
    bool scan = false, odometry = false, pressure = false, imu = false;
  };
  Sensors sensorsOf(const std::string& robot) const;
  // Throws bag::BagError for a corrupt database (records returned before stay valid).
  bool next(SensorRecord& record);
  const SensorBagStats& stats() const { return stats_; }
  bag::BagReader& bag() { return bag_; }

 private:
  enum class Kind { kOther, kScan, kOdometry, kPressure, kImu, kTfStatic, kTf };
  struct TopicState {
    Kind kind = Kind::kOther;
    std::string robot;
    std::optional<double> last_stamp;
  };

  bag::BagReader bag_;
  std::vector<TopicState> topics_;                        // by bag topic index
  std::map<std::string, geometry::Pose2> frame_offsets_;  // child frame -> pose in parent
  SensorBagStats stats_;
};

}  // namespace storey::runtime
