#include "storey/floor_mapper/floor_mapper_component.h"

#include <algorithm>

#include "storey/common/log.h"
#include "storey/floor_mapper/conversions.h"
#include "storey/runtime/floor_event_conversions.h"
#include "storey/runtime/sensor_bag.h"
#include "storey/runtime/sensor_conversions.h"

namespace storey::floor_mapper {

using common::str;

FloorMapperComponentOptions readFloorMapperComponentOptions(const common::ConfigNode& node) {
  FloorMapperComponentOptions o;
  o.robot = node.get<std::string>("robot");
  o.topics = runtime::readSensorTopics(node, o.robot, o.topics, false);
  o.events_topic = node.get<std::string>("events_topic", o.events_topic);
  o.floor_graph_topic = node.get<std::string>("floor_graph_topic", o.floor_graph_topic);
  if (o.events_topic.empty()) node.fail("events_topic", "must not be empty");
  if (o.floor_graph_topic.empty()) node.fail("floor_graph_topic", "must not be empty");
  try {
    runtime::robotTopic(o.robot, o.events_topic);
  } catch (const std::invalid_argument& e) {
    node.fail("events_topic", e.what());
  }
  o.initial_floor = node.getInt("initial_floor", o.initial_floor, -1000, 1000);
  o.initial_height = node.getDouble("initial_height", o.initial_height, -1e4, 1e4);
  o.first_floor_graph_id = node.getInt("first_floor_graph_id", o.first_floor_graph_id, -1, 2000000000L);
  o.input = mapping::readInputSequencerOptions(node);
  o.input_log = node.get<std::string>("input_log", o.input_log);
  o.slam = mapping::readFloorSlamOptions(node.child("slam"));
  node.finish();
  return o;
}

int floorGraphIdBase(const std::string& robot) {
  std::uint32_t hash = 2166136261u;
  for (const unsigned char c : robot) hash = (hash ^ c) * 16777619u;
  return static_cast<int>(hash % (1u << 20)) * 1000;
}

FloorMapperComponent::FloorMapperComponent(runtime::Context& context, const common::ConfigNode& parameters,
                                           std::string name)
    : runtime::Component(context, parameters, std::move(name)) {}

std::uint64_t FloorMapperComponent::updatesPublished() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return published_;
}

ScanCounts FloorMapperComponent::scanCounts() const {
  std::lock_guard<std::mutex> lock(mutex_);
  ScanCounts counts;
  counts.received = scans_received_;
  counts.rejected = scans_rejected_;
  if (sequencer_) counts.without_odometry = sequencer_->stats().scans_without_odometry;
  return counts;
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
    const int first_graph_id = options_.first_floor_graph_id >= 0 ? static_cast<int>(options_.first_floor_graph_id)
                                                                   : floorGraphIdBase(options_.robot);
    sessions_ = std::make_unique<mapping::FloorSessions>(options_.slam, options_.robot, options_.initial_floor,
                                                         options_.initial_height, first_graph_id);
    // Inputs are queued, not mapped, until activate (nothing is published before it).
    sequencer_ = std::make_unique<mapping::InputSequencer>(
        options_.input,
        [this](const sensor::LaserScan& scan, const geometry::Pose2& odometry) {
          if (input_log_) input_log_->appendScan(scan, odometry);
          addScan(scan, odometry);
        },
        [this](const floor::FloorEvent& event) {
          if (input_log_) input_log_->appendFloorEvent(event);
          applyFloorEvent(event);
        },
        name());
    sequencer_->setPaused(true);
    input_log_.reset();
    unmounted_.clear();
    mounting_warned_ = false;
    sequence_.clear();
    published_ = 0;
  }
  const std::string& robot = options_.robot;
  publisher_ = createPublisher<storey_msgs::msg::FloorGraphUpdate, storey_msgs::msg::FloorGraphUpdatePubSubType>(
      options_.floor_graph_topic, runtime::TopicKind::kGraph);
  identity_publisher_ =
      createPublisher<storey_msgs::msg::FloorIdentity, storey_msgs::msg::FloorIdentityPubSubType>(
          runtime::robotTopic(robot, "floor_identity"), runtime::TopicKind::kGraph);
  createSubscription<nav_msgs::msg::Odometry, nav_msgs::msg::OdometryPubSubType>(
      runtime::robotTopic(robot, options_.topics.odom), runtime::TopicKind::kSensor,
      [this](const nav_msgs::msg::Odometry& m) { onOdometry(m); });
  // The laser's mounting comes, as in ROS 2, from tf_static (base_link -> laser, or a chain).
  createSubscription<tf2_msgs::msg::TFMessage, tf2_msgs::msg::TFMessagePubSubType>(
      "tf_static", runtime::TopicKind::kGraph, [this](const tf2_msgs::msg::TFMessage& m) { onTfStatic(m); });
  createSubscription<sensor_msgs::msg::LaserScan, sensor_msgs::msg::LaserScanPubSubType>(
      runtime::robotTopic(robot, options_.topics.scan), runtime::TopicKind::kSensor,
      [this](const sensor_msgs::msg::LaserScan& m) { onScan(m); });
  createSubscription<storey_msgs::msg::FloorEvent, storey_msgs::msg::FloorEventPubSubType>(
      runtime::robotTopic(robot, options_.events_topic), runtime::TopicKind::kGraph,
      [this](const storey_msgs::msg::FloorEvent& m) { onFloorEvent(m); });
  common::logInfo(str(name(), ": mapping floors of '", robot, "', graphs on ", options_.floor_graph_topic));
}

// A restart: the input log is replayed through the same steps, which rebuilds the graphs
// and re-publishes the same updates (same sequence numbers: subscribers that had them
// ignore them, the graph server and matchers that joined since need them), then mapping
// resumes after the last logged input.
void FloorMapperComponent::onActivate() {
  std::lock_guard<std::mutex> lock(mutex_);
  if (!options_.input_log.empty() && !input_log_) {
    if (publisher_) publisher_->setActive(true);  // the replayed updates go out now
    input_log_ = std::make_unique<mapping::InputLog>(options_.input_log, [this](const mapping::LoggedInput& in) {
      if (in.is_scan) addScan(in.scan, in.odometry);
      else applyFloorEvent(in.event);
    });
    if (input_log_->existingInputs() > 0) {
      sequencer_->resumeAfter(input_log_->lastScanStamp(), input_log_->lastEventDecidedAt());
      common::logInfo(str(name(), ": resumed ", input_log_->existingInputs(), " inputs from ", options_.input_log,
                          " (scans up to t=", input_log_->lastScanStamp(), "), ", published_, " updates re-sent"));
    }
  }
  sequencer_->setPaused(false);
}

void FloorMapperComponent::onDeactivate() {
  std::lock_guard<std::mutex> lock(mutex_);
  if (sequencer_) sequencer_->setPaused(true);
}

void FloorMapperComponent::onCleanup() {
  std::lock_guard<std::mutex> lock(mutex_);
  input_log_.reset();
  sequencer_.reset();
  sessions_.reset();
  publisher_.reset();
  identity_publisher_.reset();
}

void FloorMapperComponent::onOdometry(const nav_msgs::msg::Odometry& message) {
  const sensor::OdometrySample sample = runtime::fromMessage(message);
  std::lock_guard<std::mutex> lock(mutex_);
  odometry_frame_ = message.child_frame_id();
  if (sequencer_) sequencer_->addOdometry(sample);
}

void FloorMapperComponent::onTfStatic(const tf2_msgs::msg::TFMessage& message) {
  std::lock_guard<std::mutex> lock(mutex_);
  runtime::addStaticTransforms(message, &frames_, name());
  passMountedScans(false);
}

std::vector<std::string> FloorMapperComponent::baseFrames() const {
  return runtime::robotBaseFrames(options_.robot, odometry_frame_);
}

// tf_static and the scans are separate topics: after a restart, a durable scan history can
// arrive before the laser's mounting. A scan is mapped from where it was taken or not at
// all, so scans of a laser frame whose mounting is unknown wait for it (in order); after
// kMaxUnmounted they go on as if the laser sat at base_link, with a warning.
void FloorMapperComponent::onScan(const sensor_msgs::msg::LaserScan& message) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (!sequencer_) return;
  ++scans_received_;
  unmounted_.emplace_back(message.header().frame_id(), runtime::fromMessage(message, geometry::Pose2()));
  passMountedScans(false);
}

void FloorMapperComponent::passMountedScans(bool all) {
  constexpr std::size_t kMaxUnmounted = 400;
  const std::vector<std::string> bases = baseFrames();
  while (!unmounted_.empty()) {
    auto& [frame, scan] = unmounted_.front();
    // A laser frame that is itself a base frame needs no tf_static.
    if (const auto mounting = frames_.poseInFirstOf(frame, bases)) {
      scan.sensor_offset = *mounting;
    } else if (!all && unmounted_.size() <= kMaxUnmounted) {
      return;
    } else if (!mounting_warned_) {
      std::string names;
      for (const std::string& base : bases) names += (names.empty() ? "" : ", ") + base;
      common::logWarn(str(name(), ": no tf_static mounting of laser frame '", frame,
                          "' on the robot's base (", names,
                          "); its scans are taken as if at the base"));
      mounting_warned_ = true;
    }
    sequencer_->addScan(std::move(scan));
    unmounted_.pop_front();
  }
}

void FloorMapperComponent::addScan(const sensor::LaserScan& scan, const geometry::Pose2& odometry) {
  if (sessions_->addScan(scan, odometry).status == mapping::ScanStatus::kRejected)
    ++scans_rejected_;
  publishUpdates();
  publishIdentities();
}

// Taken in any state: the topic is transient local, and history that arrives between
// configure and activate is part of the input.
void FloorMapperComponent::onFloorEvent(const storey_msgs::msg::FloorEvent& message) {
  floor::FloorEvent event;
  try {
    event = runtime::fromMessage(message);
  } catch (const std::invalid_argument& e) {
    common::logWarn(str(name(), ": ignoring a floor event: ", e.what()));
    return;
  }
  std::lock_guard<std::mutex> lock(mutex_);
  if (sequencer_) sequencer_->addFloorEvent(event);
}

void FloorMapperComponent::applyFloorEvent(const floor::FloorEvent& event) {
  if (event.type == floor::FloorEventType::kTransitStarted) {
    sessions_->beginTransit();
  } else if (event.type == floor::FloorEventType::kAwaitingIdentity) {
    sessions_->decideIdentity();
  } else {
    sessions_->endTransit(event);
  }
  publishUpdates();  // the floor just left was optimised once more
  publishIdentities();
}

void FloorMapperComponent::publishIdentities() {
  for (const auto& identity : sessions_->takeIdentities())
    if (identity_publisher_)
      identity_publisher_->publish(runtime::toMessage(identity, options_.robot));
}

bool FloorMapperComponent::flush(double timeout_s) {
  (void)timeout_s;  // optimisation is synchronous
  std::lock_guard<std::mutex> lock(mutex_);
  if (sessions_) {
    passMountedScans(true);
    sequencer_->flush();
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
