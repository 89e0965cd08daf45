#include "storey/tools/replay.h"

#include <chrono>
#include <filesystem>
#include <sstream>
#include <thread>

#include "nav_msgs/msg/OdometryPubSubTypes.h"
#include "sensor_msgs/msg/FluidPressurePubSubTypes.h"
#include "sensor_msgs/msg/ImuPubSubTypes.h"
#include "sensor_msgs/msg/LaserScanPubSubTypes.h"
#include "storey/bag/bag_error.h"
#include "storey/common/log.h"
#include "storey/io/carmen.h"
#include "storey/runtime/publisher.h"
#include "storey/runtime/sensor_conversions.h"
#include "tf2_msgs/msg/TFMessagePubSubTypes.h"

namespace storey::tools {
namespace fs = std::filesystem;

std::string ReplaySummary::text() const {
  std::ostringstream out;
  out << "replayed " << total << " messages covering " << (last_stamp - first_stamp) << " s of recording in "
      << wall_seconds << " s";
  if (wall_seconds > 0) out << " (" << (last_stamp - first_stamp) / wall_seconds << "x real time)";
  out << "\n";
  for (const auto& [topic, count] : published) out << "  " << topic << ": " << count << "\n";
  if (skipped) out << "  skipped: " << skipped << " (other types or unreadable)\n";
  if (out_of_order) out << "  stamps going backwards: " << out_of_order << "\n";
  if (stopped) out << "  interrupted before the end\n";
  if (!cut_short.empty()) out << "  ended early: " << cut_short << "\n";
  if (!unacknowledged.empty()) {
    out << "  not every reliable subscriber acknowledged every sample in time on:";
    for (const auto& topic : unacknowledged) out << " " << topic;
    out << "\n";
  }
  return out.str();
}

bool isBag(const std::string& path) {
  if (fs::is_directory(path)) return fs::exists(fs::path(path) / "metadata.yaml") || !fs::is_empty(path);
  return fs::path(path).extension() == ".db3" || fs::path(path).extension() == ".mcap";
}

bool isCarmenLog(const std::string& path) {
  const std::string name = fs::path(path).filename().string();
  auto ends = [&](const std::string& s) { return name.size() >= s.size() && name.compare(name.size() - s.size(), s.size(), s) == 0; };
  return fs::is_regular_file(path) && (ends(".log") || ends(".log.gz") || ends(".gfs") || ends(".gfs.gz") ||
                                       ends(".clf") || ends(".clf.gz"));
}

namespace {

class BagSource : public SensorSource {
 public:
  BagSource(const std::string& path, const runtime::SensorTopics& topics)
      : path_(path), reader_(path, topics) {}
  bool next(runtime::SensorRecord& record) override { return reader_.next(record); }
  std::uint64_t skipped() const override { return reader_.stats().skipped + reader_.stats().malformed; }
  std::uint64_t outOfOrder() const override { return reader_.stats().out_of_order; }
  std::string skippedNote() const override {
    const auto& s = reader_.stats();
    if (s.skipped_topics.empty()) return "";
    std::string note =
        path_ + ": " + std::to_string(s.skipped) + " messages skipped on topics not read:";
    for (const std::string& topic : s.skipped_topics) note += " " + topic;
    return note +
           " (a sensor topic is read when scan_topic, odom_topic, imu_topic or pressure_topic "
           "names it)";
  }

 private:
  std::string path_;
  runtime::SensorBagReader reader_;
};

// A CARMEN log as one robot: each laser reading gives an odometry sample (its odometry
// pose) followed by the scan; ODOM lines between readings are published as odometry too.
class CarmenSource : public SensorSource {
 public:
  CarmenSource(const std::string& path, const std::string& robot) : path_(path), robot_(robot) {
    io::CarmenReaderOptions options;
    options.strict = false;
    reader_ = std::make_unique<io::CarmenReader>(path, options);
  }
  bool next(runtime::SensorRecord& out) override {
    if (pending_) {
      out = std::move(*pending_);
      pending_.reset();
      return true;
    }
    io::CarmenRecord record;
    while (reader_->next(&record)) {
      if (record.kind != io::CarmenRecordKind::kLaser || !record.laser.has_pose || record.laser.laser_id != 1)
        continue;  // raw ODOM lines are noisy duplicates in corrected logs; rear lasers unused
      sensor::OdometrySample odom;
      odom.stamp = record.laser.scan.stamp;
      odom.pose = record.laser.odom_pose;
      if (odom.stamp < last_stamp_) ++out_of_order_;
      last_stamp_ = odom.stamp;
      out = runtime::SensorRecord{robot_, robot_ + "/odom", odom.stamp, 0, odom};
      pending_ = runtime::SensorRecord{robot_, robot_ + "/scan", odom.stamp, 0, record.laser.scan};
      return true;
    }
    return false;
  }
  std::uint64_t skipped() const override { return reader_->stats().skipped + reader_->stats().unknownCount(); }
  std::string skippedNote() const override { return io::skippedLinesNote(path_, reader_->stats()); }
  std::uint64_t outOfOrder() const override { return out_of_order_; }

 private:
  std::string path_;
  std::string robot_;
  std::unique_ptr<io::CarmenReader> reader_;
  std::optional<runtime::SensorRecord> pending_;
  double last_stamp_ = -std::numeric_limits<double>::infinity();
  std::uint64_t out_of_order_ = 0;
};

}  // namespace

std::unique_ptr<SensorSource> openSensorSource(const std::string& path, const ReplayOptions& options) {
  if (!fs::exists(path)) throw std::runtime_error(path + ": no such file or folder");
  if (isCarmenLog(path)) return std::make_unique<CarmenSource>(path, options.log_robot);
  if (isBag(path)) return std::make_unique<BagSource>(path, options.topics);
  throw std::runtime_error(path + ": neither a rosbag2 bag nor a CARMEN log (.log, .log.gz, .gfs)");
}

struct SensorReplayer::Publishers {
  // A robot's topics under `prefix` (robotTopic's names without their leading '/').
  Publishers(runtime::Context& context, const std::string& prefix, const std::string& robot,
             const runtime::SensorTopics& names)
      : scan(context, prefix + runtime::robotTopic(robot, names.scan).substr(1),
             runtime::TopicKind::kSensor),
        odom(context, prefix + runtime::robotTopic(robot, names.odom).substr(1),
             runtime::TopicKind::kSensor),
        pressure(context, prefix + runtime::robotTopic(robot, names.pressure).substr(1),
                 runtime::TopicKind::kSensor),
        imu(context, prefix + runtime::robotTopic(robot, names.imu).substr(1),
            runtime::TopicKind::kSensor) {}
  runtime::Publisher<sensor_msgs::msg::LaserScan, sensor_msgs::msg::LaserScanPubSubType> scan;
  runtime::Publisher<nav_msgs::msg::Odometry, nav_msgs::msg::OdometryPubSubType> odom;
  runtime::Publisher<sensor_msgs::msg::FluidPressure, sensor_msgs::msg::FluidPressurePubSubType> pressure;
  runtime::Publisher<sensor_msgs::msg::Imu, sensor_msgs::msg::ImuPubSubType> imu;
};

SensorReplayer::SensorReplayer(runtime::Context& context, const ReplayOptions& options)
    : context_(context), options_(options) {}

SensorReplayer::~SensorReplayer() = default;

SensorReplayer::Publishers& SensorReplayer::publishersFor(const std::string& robot) {
  auto& slot = publishers_[robot];
  if (!slot) {
    slot = std::make_unique<Publishers>(context_, options_.topic_prefix, robot, options_.topics);
    if (options_.min_subscribers > 0) {
      const double t = options_.subscriber_timeout;
      const bool matched = slot->scan.waitForSubscribers(options_.min_subscribers, t) &&
                           slot->odom.waitForSubscribers(1, t) && slot->pressure.waitForSubscribers(1, t) &&
                           slot->imu.waitForSubscribers(1, t);
      if (!matched)
        throw std::runtime_error("replay: no " + std::to_string(options_.min_subscribers) +
                                 " subscribers on the topics of '" + robot + "' within " + std::to_string(t) + " s");
    }
    if (options_.settle_seconds > 0)
      std::this_thread::sleep_for(std::chrono::duration<double>(options_.settle_seconds));
  }
  return *slot;
}

void SensorReplayer::publishLaserOffset(const std::string& robot, const sensor::LaserScan& scan) {
  // LaserScan carries no mounting; as in ROS 2 it goes to tf_static (transient local), once
  // per robot and whenever it changes.
  auto known = laser_offsets_.find(robot);
  if (known != laser_offsets_.end() && known->second.vector() == scan.sensor_offset.vector()) return;
  laser_offsets_[robot] = scan.sensor_offset;
  if (!tf_static_)
    tf_static_ = std::make_unique<runtime::Publisher<tf2_msgs::msg::TFMessage, tf2_msgs::msg::TFMessagePubSubType>>(
        context_, options_.topic_prefix + "tf_static", runtime::TopicKind::kGraph);
  tf2_msgs::msg::TFMessage tf;
  for (const auto& [name, offset] : laser_offsets_)
    tf.transforms().push_back(runtime::toTransform(offset, scan.stamp, runtime::robotFrame(name, "base_link"),
                                                   runtime::robotFrame(name, "laser")));
  tf_static_->publish(tf);
}

void SensorReplayer::publish(const runtime::SensorRecord& record) {
  Publishers& p = publishersFor(record.robot);
  std::visit(
      [&](const auto& sample) {
        using T = std::decay_t<decltype(sample)>;
        if constexpr (std::is_same_v<T, sensor::LaserScan>) {
          publishLaserOffset(record.robot, sample);
          p.scan.publish(runtime::toMessage(sample, runtime::robotFrame(record.robot, "laser")));
        } else if constexpr (std::is_same_v<T, sensor::OdometrySample>) {
          p.odom.publish(runtime::toMessage(sample, runtime::robotFrame(record.robot, "odom"),
                                            runtime::robotFrame(record.robot, "base_link")));
        } else if constexpr (std::is_same_v<T, sensor::PressureSample>) {
          p.pressure.publish(runtime::toMessage(sample, runtime::robotFrame(record.robot, "base_link")));
        } else {
          p.imu.publish(runtime::toMessage(sample, runtime::robotFrame(record.robot, "imu")));
        }
      },
      record.data);
}

ReplaySummary SensorReplayer::replay(SensorSource& source, const std::atomic<bool>* stop,
                                     const std::function<void(std::uint64_t, std::uint64_t)>& progress) {
  ReplaySummary summary;
  const auto wall_start = std::chrono::steady_clock::now();
  runtime::SensorRecord record;
  bool first = true;
  double recording_start = 0.0;
  auto next = [&] {
    try {
      return source.next(record);
    } catch (const bag::BagError& e) {
      summary.cut_short = e.what();
      return false;
    }
  };
  while (next()) {
    if (stop && stop->load()) {
      summary.stopped = true;
      break;
    }
    if (first) {
      summary.first_stamp = summary.last_stamp = recording_start = record.stamp;
      first = false;
    }
    if (options_.rate > 0.0) {
      const auto due = wall_start + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                                        std::chrono::duration<double>((record.stamp - recording_start) / options_.rate));
      std::this_thread::sleep_until(due);
    }
    publish(record);
    if (options_.after_each) options_.after_each();
    ++summary.published[options_.topic_prefix + record.topic.substr(record.topic.front() == '/' ? 1 : 0)];
    ++summary.total;
    summary.first_stamp = std::min(summary.first_stamp, record.stamp);
    summary.last_stamp = std::max(summary.last_stamp, record.stamp);
    if (progress && summary.total % 200 == 0) progress(summary.total, source.expectedCount());
  }
  // Reliable subscribers get everything before the replay ends (waited for at most
  // ack_seconds: a subscriber killed mid-replay is only dropped after its lease).
  if (!summary.stopped && options_.ack_seconds > 0.0) {
    // Said before the wait: a late-joining reliable subscriber catching up on the history
    // can take seconds (8 s in the fault tests), and whoever watches may want to know.
    common::logInfo(common::str("replay: all ", summary.total, " messages published; waiting up to ",
                                options_.ack_seconds, " s for reliable subscribers' acknowledgments"));
    const auto ack_end = std::chrono::steady_clock::now() + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                                                              std::chrono::duration<double>(options_.ack_seconds));
    auto left = [&] { return std::max(0.0, std::chrono::duration<double>(ack_end - std::chrono::steady_clock::now()).count()); };
    for (auto& [robot, p] : publishers_) {
      // A subscriber restarted mid-replay that has not matched again yet would miss
      // whatever this process alone still holds: wait for it too.
      if (options_.min_subscribers > 0 && !p->scan.waitForSubscribers(options_.min_subscribers, left()))
        summary.unacknowledged.push_back(p->scan.topic() + " (fewer than " +
                                         std::to_string(options_.min_subscribers) + " subscribers)");
      for (const runtime::PublisherBase* w :
           std::initializer_list<const runtime::PublisherBase*>{&p->scan, &p->odom, &p->pressure, &p->imu})
        if (!w->waitForAcknowledgments(left())) summary.unacknowledged.push_back(w->topic());
    }
    if (tf_static_ && !tf_static_->waitForAcknowledgments(left())) summary.unacknowledged.push_back(tf_static_->topic());
  }
  summary.skipped = source.skipped();
  summary.out_of_order = source.outOfOrder();
  summary.wall_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
  if (progress) progress(summary.total, summary.total);
  return summary;
}

}  // namespace storey::tools
