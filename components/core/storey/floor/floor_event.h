// A robot's change of floor as the floor detector reports it and the floor mapper and the
// components consume it: the one type the detection and mapping stages share, kept below
// both (docs/architecture.md).
#pragma once

namespace storey::floor {

enum class TransitMode { kUnknown = 0, kElevator = 1, kStairs = 2 };
const char* transitModeName(TransitMode mode);

// kProgress is not a change of floor: the floor_detector component sends it now and then
// so that a consumer (the floor mapper) knows that no event decided up to `decided_at`
// is still to come, and can order scans and events by their stamps (docs/floor_mapper.md).
enum class FloorEventType { kTransitStarted = 0, kTransitEnded = 1, kProgress = 2 };

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
};

}  // namespace storey::floor
