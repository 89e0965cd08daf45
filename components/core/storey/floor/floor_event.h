// A robot's change of floor as the floor detector reports it and the floor mapper and the
// components consume it: the one type the detection and mapping stages share, kept below
// both (docs/architecture.md).
#pragma once

#include <vector>

namespace storey::floor {

enum class TransitMode { kUnknown = 0, kElevator = 1, kStairs = 2 };
const char* transitModeName(TransitMode mode);

// kProgress is not a change of floor: the floor_detector component sends it now and then
// so that a consumer (the floor mapper) knows that no event decided up to `decided_at`
// is still to come, and can order scans and events by their stamps (docs/floor_mapper.md).
// kAwaitingIdentity is not a change of floor either: the detector has stopped before the
// next ride until the floor mapper names the floor an unsure arrival reached (see
// FloorEvent::candidate_floors); the mapper decides with the scans up to `decided_at`.
enum class FloorEventType {
  kTransitStarted = 0,
  kTransitEnded = 1,
  kProgress = 2,
  kAwaitingIdentity = 3
};

// One event. TransitStarted fills stamp, from_floor and from_height; TransitEnded fills
// everything.
struct FloorEvent {
  FloorEventType type = FloorEventType::kTransitStarted;
  double stamp = 0.0;  // s: start of the vertical motion, or its end
  // s: the pressure stamp at which the detector decided the event (later than `stamp`:
  // a ride is confirmed after it began). Scans up to it were mapped on the floor before.
  double decided_at = 0.0;
  double start_stamp = 0.0;  // s: start of the ride (TransitEnded)
  int from_floor = 0;
  double from_height = 0.0;    // m, building frame
  double height_change = 0.0;  // m, from the floor left (up is positive), by the barometer
  double height_change_stddev = 0.0;
  int floor_id = 0;           // floor reached (== from_floor when the floor did not change)
  double floor_height = 0.0;  // m, that floor's height estimate
  bool floor_changed = false;
  bool new_floor = false;   // the floor was created by this ride
  double confidence = 0.0;  // in (0, 1), see docs/floor_detector.md
  TransitMode mode = TransitMode::kUnknown;
  // An arrival the height alone does not decide (TransitEnded): the known floors whose
  // heights are within reach of the height change's uncertainty (floor_id among them when
  // it is known), and the id a floor never seen would get (new_floor_id, -1 when the height
  // rules a new floor out). Empty when the height decides. The floor mapper localises the
  // arriving scans in those floors' maps and answers with a FloorIdentity.
  std::vector<int> candidate_floors;
  int new_floor_id = -1;
  double new_floor_height = 0.0;  // m, the height that new floor would get
  bool identityUnsure() const { return !candidate_floors.empty(); }
};

// The floor mapper's answer to an unsure arrival: the floor the robot reached.
struct FloorIdentity {
  double ride_end = 0.0;   // s: `stamp` of the TransitEnded it answers
  int floor_id = 0;        // a known floor, or the event's new_floor_id
  bool localized = false;  // found in that floor's map; false: no map decided, the height's choice
};

}  // namespace storey::floor
