#include "storey/runtime/sensor_bag.h"

#include <algorithm>
#include <optional>
#include <set>
#include <stdexcept>

#include "storey/common/log.h"
#include "tf2_msgs/msg/TFMessage.h"

namespace storey::runtime {
namespace {

constexpr int kMaxWarnings = 5;

}  // namespace

SensorBagWriter::SensorBagWriter(const std::string& folder, const bag::BagWriterOptions& options)
    : bag_(folder, options) {}

SensorBagWriter::~SensorBagWriter() {
  try {
    close();
  } catch (const std::exception& e) {
    common::logError(common::str("closing sensor bag: ", e.what()));
  }
}

void SensorBagWriter::close() {
  std::lock_guard<std::mutex> lock(mutex_);
  bag_.close();
}

void SensorBagWriter::declare(const std::string& topic, const std::string& type, bool reliable) {
  if (!bag_.hasTopic(topic)) {
    const bool transient_local = isTfStaticTopic(topic);
    bag_.createTopic(
        {topic, type, bag::kSerializationCdr, bag::qosProfileYaml(reliable, transient_local)});
  }
}

void SensorBagWriter::write(const std::string& robot, const sensor::LaserScan& scan) {
  std::lock_guard<std::mutex> lock(mutex_);
  const std::string topic = robotTopic(robot, "scan");
  const std::string laser_frame = robotFrame(robot, "laser");
  writeStatic(robotFrame(robot, "base_link"), laser_frame, scan.sensor_offset, scan.stamp);
  writeLocked(topic, kLaserScanType, scan.stamp, toMessage(scan, laser_frame));
}

void SensorBagWriter::writeStatic(const std::string& parent, const std::string& child,
                                  const geometry::Pose2& pose, double stamp) {
  const auto known = static_frames_.find(child);
  if (known != static_frames_.end() && known->second.first == parent &&
      known->second.second.x() == pose.x() && known->second.second.y() == pose.y() &&
      known->second.second.theta() == pose.theta())
    return;
  static_frames_[child] = {parent, pose};
  tf2_msgs::msg::TFMessage tf;
  for (const auto& [frame, mounting] : static_frames_)
    tf.transforms().push_back(toTransform(mounting.second, stamp, mounting.first, frame));
  writeLocked(kTfStaticTopic, kTfMessageType, stamp, tf, /*reliable=*/true);
}

void SensorBagWriter::write(const std::string& robot, const sensor::OdometrySample& odom) {
  std::lock_guard<std::mutex> lock(mutex_);
  const std::string odom_frame = robotFrame(robot, "odom");
  const std::string base_frame = robotFrame(robot, "base_link");
  writeLocked(robotTopic(robot, "odom"), kOdometryType, odom.stamp,
              toMessage(odom, odom_frame, base_frame));
  // The same pose as odom -> base_link on /tf (REP 105), so tools can place the robot.
  tf2_msgs::msg::TFMessage tf;
  tf.transforms().push_back(toTransform(odom.pose, odom.stamp, odom_frame, base_frame));
  writeLocked(kTfTopic, kTfMessageType, odom.stamp, tf, /*reliable=*/true);
}

void SensorBagWriter::write(const std::string& robot, const sensor::PressureSample& pressure) {
  std::lock_guard<std::mutex> lock(mutex_);
  writeLocked(robotTopic(robot, "pressure"), kFluidPressureType, pressure.stamp,
              toMessage(pressure, robotFrame(robot, "base_link")));
}

void SensorBagWriter::write(const std::string& robot, const sensor::ImuSample& imu) {
  std::lock_guard<std::mutex> lock(mutex_);
  // The simulated and logged IMUs sit at the robot's base.
  writeStatic(robotFrame(robot, "base_link"), robotFrame(robot, "imu"), geometry::Pose2(),
              imu.stamp);
  writeLocked(robotTopic(robot, "imu"), kImuType, imu.stamp,
              toMessage(imu, robotFrame(robot, "imu")));
}

SensorBagReader::SensorBagReader(const std::string& path, const SensorTopics& names) : bag_(path) {
  for (const bag::TopicInfo& info : bag_.topics()) {
    TopicState state;
    // A sensor topic of its type, when the robots' topic names name it.
    auto sensor = [&](Kind kind, const std::string& leaf) {
      if (const auto robot = robotOfTopic(info.name, leaf)) {
        state.kind = kind;
        state.robot = *robot;
      }
    };
    if (info.serialization_format != bag::kSerializationCdr) {
      state.kind = Kind::kOther;
    } else if (info.type == kLaserScanType) {
      sensor(Kind::kScan, names.scan);
    } else if (info.type == kOdometryType) {
      sensor(Kind::kOdometry, names.odom);
    } else if (info.type == kFluidPressureType) {
      sensor(Kind::kPressure, names.pressure);
    } else if (info.type == kImuType) {
      sensor(Kind::kImu, names.imu);
    } else if (info.type == kTfMessageType && info.name == kTfStaticTopic) {
      state.kind = Kind::kTfStatic;
    } else if (info.type == kTfMessageType && info.name == kTfTopic) {
      state.kind = Kind::kTf;  // what the odometry topics carry: not needed
    }
    if (state.kind == Kind::kOther) stats_.skipped_topics.push_back(info.name);
    topics_.push_back(std::move(state));
  }
}

std::vector<std::string> SensorBagReader::robots() const {
  std::set<std::string> names;
  for (const TopicState& t : topics_) {
    if (t.kind != Kind::kOther && t.kind != Kind::kTfStatic && t.kind != Kind::kTf)
      names.insert(t.robot);
  }
  return {names.begin(), names.end()};
}

SensorBagReader::Sensors SensorBagReader::sensorsOf(const std::string& robot) const {
  Sensors s;
  for (const TopicState& t : topics_) {
    if (t.robot != robot) continue;
    s.scan = s.scan || t.kind == Kind::kScan;
    s.odometry = s.odometry || t.kind == Kind::kOdometry;
    s.pressure = s.pressure || t.kind == Kind::kPressure;
    s.imu = s.imu || t.kind == Kind::kImu;
  }
  return s;
}

bool SensorBagReader::next(SensorRecord& record) {
  bag::BagMessage message;
  while (bag_.next(message)) {
    TopicState& topic = topics_[message.topic_index];
    const std::string& name = bag_.topics()[message.topic_index].name;
    if (topic.kind == Kind::kOther) {
      ++stats_.skipped;
      continue;
    }
    try {
      const std::uint8_t* data = message.data.data();
      const std::size_t size = message.data.size();
      switch (topic.kind) {
        case Kind::kTf:
          continue;
        case Kind::kTfStatic: {
          tf2_msgs::msg::TFMessage tf;
          deserializeCdr(data, size, tf, kTfMessageType);
          for (const auto& t : tf.transforms())
            frame_offsets_[t.child_frame_id()] = fromTransform(t);
          continue;
        }
        case Kind::kScan: {
          sensor_msgs::msg::LaserScan msg;
          deserializeCdr(data, size, msg, kLaserScanType);
          const auto offset = frame_offsets_.find(msg.header().frame_id());
          record.data =
              fromMessage(msg, offset == frame_offsets_.end() ? geometry::Pose2() : offset->second);
          record.stamp = std::get<sensor::LaserScan>(record.data).stamp;
          break;
        }
        case Kind::kOdometry: {
          nav_msgs::msg::Odometry msg;
          deserializeCdr(data, size, msg, kOdometryType);
          record.data = fromMessage(msg);
          record.stamp = std::get<sensor::OdometrySample>(record.data).stamp;
          break;
        }
        case Kind::kPressure: {
          sensor_msgs::msg::FluidPressure msg;
          deserializeCdr(data, size, msg, kFluidPressureType);
          record.data = fromMessage(msg);
          record.stamp = std::get<sensor::PressureSample>(record.data).stamp;
          break;
        }
        case Kind::kImu: {
          sensor_msgs::msg::Imu msg;
          deserializeCdr(data, size, msg, kImuType);
          record.data = fromMessage(msg);
          record.stamp = std::get<sensor::ImuSample>(record.data).stamp;
          break;
        }
        case Kind::kOther:
          break;
      }
    } catch (const CdrError& e) {
      if (++stats_.malformed <= kMaxWarnings) {
        common::logWarn(common::str(bag_.path(), ": topic ", name, " at ", message.stamp_ns,
                                    " ns: skipped: ", e.what()));
      }
      continue;
    }
    if (topic.last_stamp && record.stamp < *topic.last_stamp) ++stats_.out_of_order;
    topic.last_stamp = record.stamp;
    record.robot = topic.robot;
    record.topic = name;
    record.bag_stamp_ns = message.stamp_ns;
    ++stats_.yielded;
    return true;
  }
  return false;
}

}  // namespace storey::runtime
