#include "storey/runtime/floor_event_conversions.h"

#include <cmath>
#include <stdexcept>
#include <vector>

#include "storey/runtime/sensor_conversions.h"

namespace storey::runtime {

namespace {
constexpr std::int32_t kFloorUnknown = -1;

std::uint8_t toMode(floor::TransitMode mode) {
  switch (mode) {
    case floor::TransitMode::kElevator:
      return storey_msgs::msg::FloorEvent_Constants::MODE_ELEVATOR;
    case floor::TransitMode::kStairs:
      return storey_msgs::msg::FloorEvent_Constants::MODE_STAIRS;
    default:
      return storey_msgs::msg::FloorEvent_Constants::MODE_UNKNOWN;
  }
}

std::uint8_t toKind(floor::FloorEventType type) {
  namespace k = storey_msgs::msg::FloorEvent_Constants;
  switch (type) {
    case floor::FloorEventType::kTransitStarted:
      return k::KIND_TRANSIT_STARTED;
    case floor::FloorEventType::kTransitEnded:
      return k::KIND_TRANSIT_ENDED;
    case floor::FloorEventType::kAwaitingIdentity:
      return k::KIND_AWAITING_IDENTITY;
    default:
      return k::KIND_PROGRESS;
  }
}
}  // namespace

storey_msgs::msg::FloorEvent toMessage(const floor::FloorEvent& event, const std::string& robot) {
  namespace k = storey_msgs::msg::FloorEvent_Constants;
  storey_msgs::msg::FloorEvent m;
  m.robot(robot);
  m.stamp(toTimeMessage(event.stamp));
  m.decided_at(toTimeMessage(event.decided_at));
  m.kind(toKind(event.type));
  const bool ended = event.type == floor::FloorEventType::kTransitEnded;
  const bool started = event.type == floor::FloorEventType::kTransitStarted;
  m.floor_id(ended ? event.floor_id : kFloorUnknown);
  m.new_floor(ended && event.new_floor);
  m.height_change(ended ? event.height_change : 0.0);
  m.height_change_stddev(ended ? event.height_change_stddev : 0.0);
  m.floor_height(ended ? event.floor_height : started ? event.from_height : 0.0);
  m.confidence(ended ? event.confidence : 0.0);
  m.mode(ended ? toMode(event.mode) : k::MODE_UNKNOWN);
  if (ended)
    m.candidate_floors(
        std::vector<std::int32_t>(event.candidate_floors.begin(), event.candidate_floors.end()));
  m.new_floor_id(ended && event.identityUnsure() ? event.new_floor_id : kFloorUnknown);
  m.new_floor_height(ended && event.identityUnsure() ? event.new_floor_height : 0.0);
  return m;
}

floor::FloorEvent fromMessage(const storey_msgs::msg::FloorEvent& m) {
  namespace k = storey_msgs::msg::FloorEvent_Constants;
  floor::FloorEvent e;
  switch (m.kind()) {
    case k::KIND_TRANSIT_STARTED:
      e.type = floor::FloorEventType::kTransitStarted;
      break;
    case k::KIND_TRANSIT_ENDED:
      e.type = floor::FloorEventType::kTransitEnded;
      break;
    case k::KIND_PROGRESS:
      e.type = floor::FloorEventType::kProgress;
      break;
    case k::KIND_AWAITING_IDENTITY:
      e.type = floor::FloorEventType::kAwaitingIdentity;
      break;
    default:
      throw std::invalid_argument("floor event of unknown kind " + std::to_string(m.kind()));
  }
  const bool ended = e.type == floor::FloorEventType::kTransitEnded;
  e.stamp = fromTimeMessage(m.stamp());
  const double decided = fromTimeMessage(m.decided_at());
  e.decided_at = decided == 0.0 ? e.stamp : decided;
  if (!std::isfinite(e.stamp) || !std::isfinite(e.decided_at))
    throw std::invalid_argument("floor event with a non-finite stamp");
  e.start_stamp = e.stamp;
  e.floor_id = m.floor_id();
  e.new_floor = m.new_floor();
  e.floor_changed = ended;
  e.height_change = m.height_change();
  e.height_change_stddev = m.height_change_stddev();
  e.floor_height = m.floor_height();
  if (ended && !std::isfinite(e.floor_height))
    throw std::invalid_argument("floor event with a non-finite floor height");
  if (e.type == floor::FloorEventType::kTransitStarted) e.from_height = m.floor_height();
  e.confidence = m.confidence();
  e.mode = m.mode() == k::MODE_ELEVATOR ? floor::TransitMode::kElevator
           : m.mode() == k::MODE_STAIRS ? floor::TransitMode::kStairs
                                        : floor::TransitMode::kUnknown;
  if (ended) {
    e.candidate_floors.assign(m.candidate_floors().begin(), m.candidate_floors().end());
    for (const int f : e.candidate_floors)
      if (f < 0) throw std::invalid_argument("floor event with a negative candidate floor");
    e.new_floor_id = e.identityUnsure() ? m.new_floor_id() : -1;
    e.new_floor_height = m.new_floor_height();
    if (e.identityUnsure() && !std::isfinite(e.new_floor_height))
      throw std::invalid_argument("floor event with a non-finite new floor height");
  }
  return e;
}

storey_msgs::msg::FloorIdentity toMessage(const floor::FloorIdentity& identity,
                                          const std::string& robot) {
  storey_msgs::msg::FloorIdentity m;
  m.robot(robot);
  m.ride_end(toTimeMessage(identity.ride_end));
  m.floor_id(identity.floor_id);
  m.localized(identity.localized);
  return m;
}

floor::FloorIdentity fromMessage(const storey_msgs::msg::FloorIdentity& m) {
  floor::FloorIdentity identity;
  identity.ride_end = fromTimeMessage(m.ride_end());
  if (!std::isfinite(identity.ride_end))
    throw std::invalid_argument("floor identity with a non-finite stamp");
  if (m.floor_id() < 0) throw std::invalid_argument("floor identity with a negative floor id");
  identity.floor_id = m.floor_id();
  identity.localized = m.localized();
  return identity;
}

}  // namespace storey::runtime
