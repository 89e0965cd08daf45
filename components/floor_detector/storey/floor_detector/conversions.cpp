#include "storey/floor_detector/conversions.h"

#include "storey/runtime/sensor_conversions.h"

namespace storey::floor_detector {

namespace {
constexpr std::int32_t kFloorUnknown = -1;

std::uint8_t toMode(detection::TransitMode mode) {
  switch (mode) {
    case detection::TransitMode::kElevator:
      return storey_msgs::msg::FloorEvent_Constants::MODE_ELEVATOR;
    case detection::TransitMode::kStairs:
      return storey_msgs::msg::FloorEvent_Constants::MODE_STAIRS;
    default:
      return storey_msgs::msg::FloorEvent_Constants::MODE_UNKNOWN;
  }
}
}  // namespace

storey_msgs::msg::FloorEvent toMessage(const detection::FloorEvent& event,
                                       const std::string& robot) {
  namespace k = storey_msgs::msg::FloorEvent_Constants;
  storey_msgs::msg::FloorEvent m;
  m.robot(robot);
  m.stamp(runtime::toTimeMessage(event.stamp));
  const bool ended = event.type == detection::FloorEventType::kTransitEnded;
  m.kind(ended ? k::KIND_TRANSIT_ENDED : k::KIND_TRANSIT_STARTED);
  m.floor_id(ended ? event.floor_id : kFloorUnknown);
  m.new_floor(ended && event.new_floor);
  m.height_change(ended ? event.height_change : 0.0);
  m.height_change_stddev(ended ? event.height_change_stddev : 0.0);
  m.floor_height(ended ? event.floor_height : event.from_height);
  m.confidence(ended ? event.confidence : 0.0);
  m.mode(ended ? toMode(event.mode) : k::MODE_UNKNOWN);
  return m;
}

detection::FloorEvent fromMessage(const storey_msgs::msg::FloorEvent& m) {
  namespace k = storey_msgs::msg::FloorEvent_Constants;
  detection::FloorEvent e;
  const bool ended = m.kind() == k::KIND_TRANSIT_ENDED;
  e.type =
      ended ? detection::FloorEventType::kTransitEnded : detection::FloorEventType::kTransitStarted;
  e.stamp = runtime::fromTimeMessage(m.stamp());
  e.start_stamp = e.stamp;
  e.floor_id = m.floor_id();
  e.new_floor = m.new_floor();
  e.floor_changed = ended;
  e.height_change = m.height_change();
  e.height_change_stddev = m.height_change_stddev();
  e.floor_height = m.floor_height();
  e.confidence = m.confidence();
  e.mode = m.mode() == k::MODE_ELEVATOR ? detection::TransitMode::kElevator
           : m.mode() == k::MODE_STAIRS ? detection::TransitMode::kStairs
                                        : detection::TransitMode::kUnknown;
  return e;
}

}  // namespace storey::floor_detector
