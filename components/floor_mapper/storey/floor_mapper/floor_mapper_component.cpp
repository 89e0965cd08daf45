#include "storey/floor_mapper/floor_mapper_component.h"

#include <algorithm>

#include "storey/common/log.h"
#include "storey/floor_mapper/conversions.h"
#include "storey/runtime/sensor_bag.h"
#include "storey/runtime/sensor_conversions.h"

namespace storey::floor_mapper {

using common::str;

FloorMapperComponentOptions readFloorMapperComponentOptions(const common::ConfigNode& node) {
  FloorMapperComponentOptions o;
  o.robot = node.get<std::string>("robot");
  o.events_topic = node.get<std::string>("events_topic", o.events_topic);
  o.floor_graph_topic = node.get<std::string>("floor_graph_topic", o.floor_graph_topic);
  if (o.events_topic.empty()) node.fail("events_topic", "must not be empty");
  if (o.floor_graph_topic.empty()) node.fail("floor_graph_topic", "must not be empty");
  try {
    runtime::robotTopic(o.robot, o.events_topic);
  } catch (const std::invalid_argument& e) {
    node.fail("robot", e.what());
  }
  o.initial_floor = node.getInt("initial_floor", o.initial_floor, -1000, 1000);
  o.initial_height = node.getDouble("initial_height", o.initial_height, -1e4, 1e4);
  o.max_odometry_gap = node.getDouble("max_odometry_gap", o.max_odometry_gap, 1e-3, 60.0);
  o.slam = mapping::readFloorSlamOptions(node.child("slam"));
  node.finish();
  return o;
}

FloorMapperComponent::FloorMapperComponent(runtime::Context& context, const common::ConfigNode& parameters,
                                           std::string name)
    : runtime::Component(context, parameters, std::move(name)) {}

std::uint64_t FloorMapperComponent::updatesPublished() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return published_;
}

std::size_t FloorMapperComponent::nodeCount() const {
  std::lock_guard<std::mutex> lock(mutex_);
  std::size_t n = 0;
  if (sessions_) {
    for (const auto& [floor, slam] : sessions_->floors()) n += slam->floorGraph().nodes.size();
    for (const auto& slam : sessions_->retired()) n += slam->floorGraph().nodes.size();
  }
  return n;
}

void FloorMapperComponent::onConfigure() {
  options_ = readFloorMapperComponentOptions(parameters());
  {
    std::lock_guard<std::mutex> lock(mutex_);
    sessions_ = std::make_unique<mapping::FloorSessions>(options_.slam, options_.robot, options_.initial_floor,
                                                         options_.initial_height);
    odometry_.clear();
    pending_scans_.clear();
    sequence_.clear();
    published_ = 0;
  }
  const std::string& robot = options_.robot;
  publisher_ = createPublisher<storey_msgs::msg::FloorGraphUpdate, storey_msgs::msg::FloorGraphUpdatePubSubType>(
      options_.floor_graph_topic, runtime::TopicKind::kGraph);
  createSubscription<nav_msgs::msg::Odometry, nav_msgs::msg::OdometryPubSubType>(
      runtime::robotTopic(robot, "odom"), runtime::TopicKind::kSensor,
      [this](const nav_msgs::msg::Odometry& m) { onOdometry(m); });
  // The laser's mounting comes, as in ROS 2, from tf_static (base_link -> laser).
  createSubscription<tf2_msgs::msg::TFMessage, tf2_msgs::msg::TFMessagePubSubType>(
      "tf_static", runtime::TopicKind::kGraph, [this](const tf2_msgs::msg::TFMessage& m) { onTfStatic(m); });
  createSubscription<sensor_msgs::msg::LaserScan, sensor_msgs::msg::LaserScanPubSubType>(
      runtime::robotTopic(robot, "scan"), runtime::TopicKind::kSensor,
      [this](const sensor_msgs::msg::LaserScan& m) { onScan(m); });
  createSubscription<storey_msgs::msg::FloorEvent, storey_msgs::msg::FloorEventPubSubType>(
      runtime::robotTopic(robot, options_.events_topic), runtime::TopicKind::kGraph,
      [this](const storey_msgs::msg::FloorEvent& m) { onFloorEvent(m); });
  common::logInfo(str(name(), ": mapping floors of '", robot, "', graphs on ", options_.floor_graph_topic));
}

void FloorMapperComponent::onCleanup() {
  std::lock_guard<std::mutex> lock(mutex_);
  sessions_.reset();
  publisher_.reset();
}

void FloorMapperComponent::onOdometry(const nav_msgs::msg::Odometry& message) {
  if (state() != runtime::LifecycleState::kActive) return;
  const sensor::OdometrySample sample = runtime::fromMessage(message);
  std::lock_guard<std::mutex> lock(mutex_);
  if (!std::isfinite(sample.stamp) || !sample.pose.isFinite()) return;
  if (!odometry_.empty() && sample.stamp < odometry_.back().stamp) return;  // out of order
  odometry_.push_back(sample);
  processPendingScans(false);
  // Kept 10 s back, and as far back as the oldest scan still waiting needs.
  double keep_from = sample.stamp - 10.0;
  if (!pending_scans_.empty())
    keep_from = std::min(keep_from, pending_scans_.front().stamp - options_.max_odometry_gap - 1.0);
  while (odometry_.size() > 2 && odometry_.front().stamp < keep_from) odometry_.pop_front();
}

void FloorMapperComponent::onTfStatic(const tf2_msgs::msg::TFMessage& message) {
  const std::string base = runtime::robotFrame(options_.robot, "base_link");
  std::lock_guard<std::mutex> lock(mutex_);
  for (const auto& t : message.transforms())
    if (t.header().frame_id() == base) laser_offsets_[t.child_frame_id()] = runtime::fromTransform(t);
}

void FloorMapperComponent::onScan(const sensor_msgs::msg::LaserScan& message) {
  if (state() != runtime::LifecycleState::kActive) return;
  std::lock_guard<std::mutex> lock(mutex_);
  auto mounting = laser_offsets_.find(message.header().frame_id());
  if (!sessions_) return;
  pending_scans_.push_back(
      runtime::fromMessage(message, mounting == laser_offsets_.end() ? geometry::Pose2() : mounting->second));
  processPendingScans(false);
}

// Scan and odometry topics are delivered independently; a scan handled before the
// odometry around its stamp has arrived would get another pose, or be dropped, depending
// on thread timing. So a scan waits until odometry at or after its stamp is here (or
// kMaxWaiting scans wait: then none is coming), and the result does not depend on how
// the topics interleave or how late a reliable topic's resent sample comes.
void FloorMapperComponent::processPendingScans(bool all) {
  constexpr std::size_t kMaxWaiting = 600;   // scans waiting for odometry (none is coming?)
  while (!pending_scans_.empty()) {
    const sensor::LaserScan& scan = pending_scans_.front();
    const bool odometry_after = !odometry_.empty() && odometry_.back().stamp >= scan.stamp;
    if (!all && !odometry_after && pending_scans_.size() <= kMaxWaiting) return;
    addScan(scan);
    pending_scans_.pop_front();
  }
}

void FloorMapperComponent::addScan(const sensor::LaserScan& scan) {
  // Odometry at the scan's stamp: interpolated between the samples around it, or the
  // nearest one within max_odometry_gap.
  const sensor::OdometrySample* before = nullptr;
  const sensor::OdometrySample* after = nullptr;
  for (const auto& s : odometry_) {
    if (s.stamp <= scan.stamp) before = &s;
    else if (!after) after = &s;
  }
  geometry::Pose2 odometry;
  if (before && after && after->stamp - before->stamp <= options_.max_odometry_gap) {
    odometry = geometry::interpolate(before->pose, after->pose,
                                     (scan.stamp - before->stamp) / (after->stamp - before->stamp));
  } else if (before && scan.stamp - before->stamp <= options_.max_odometry_gap) {
    odometry = before->pose;
  } else if (after && after->stamp - scan.stamp <= options_.max_odometry_gap) {
    odometry = after->pose;
  } else {
    common::logDebug(str(name(), ": no odometry near the scan at ", scan.stamp, "; scan dropped"));
    return;
  }
  sessions_->addScan(scan, odometry);
  publishUpdates();
}

void FloorMapperComponent::onFloorEvent(const storey_msgs::msg::FloorEvent& message) {
  FloorEventInfo event;
  try {
    event = fromMessage(message);
  } catch (const std::invalid_argument& e) {
    common::logWarn(str(name(), ": ignoring a floor event: ", e.what()));
    return;
  }
  std::lock_guard<std::mutex> lock(mutex_);
  if (!sessions_) return;
  // Scans from before the event belong to the floor as it was.
  const double stamp = runtime::fromTimeMessage(message.stamp());
  while (!pending_scans_.empty() && pending_scans_.front().stamp <= stamp) {
    addScan(pending_scans_.front());
    pending_scans_.pop_front();
  }
  if (event.transit_started) {
    sessions_->beginTransit();
  } else {
    sessions_->endTransit(event.floor_id, event.floor_height);
    publishUpdates();  // the floor just left was optimised once more
  }
}

bool FloorMapperComponent::flush(double timeout_s) {
  (void)timeout_s;  // optimisation is synchronous
  std::lock_guard<std::mutex> lock(mutex_);
  if (sessions_) {
    processPendingScans(true);
    sessions_->flush();
    publishUpdates();
  }
  return true;
}

void FloorMapperComponent::publishUpdates() {
  for (const auto& [floor, slam] : sessions_->floors()) {
    const mapping::GraphUpdate update = slam->takeUpdate();
    if (update.new_nodes.empty() && update.new_edges.empty() && !update.poses_changed) continue;
    const int graph_id = slam->floorGraph().graph_id;
    const std::uint32_t sequence = sequence_[graph_id]++;
    if (publisher_ && publisher_->publish(toMessage(slam->floorGraph(), update, sequence))) ++published_;
  }
}

}  // namespace storey::floor_mapper
