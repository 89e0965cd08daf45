// Compares the floor changes a detector reported with the simulator's ground truth
// (transits.csv and floors.yaml of a ground-truth folder, see docs/simulator.md): missed,
// spurious and wrong floors, and the error of the height changes.
#pragma once

#include <map>
#include <string>
#include <vector>

#include "storey/floor/floor_event.h"

namespace storey::eval {

struct TrueTransit {
  std::string robot;
  double start = 0.0, end = 0.0;  // s
  std::string from_floor, to_floor;
  double height_change = 0.0;  // m, from the floors' heights
  std::string mode;            // "elevator" or "stairs"
};

// Reads <dir>/transits.csv and <dir>/floors.yaml. Throws std::runtime_error naming the
// file and line for a missing file or a malformed row.
std::vector<TrueTransit> readTrueTransits(const std::string& dir);

struct FloorComparison {
  int true_transits = 0;
  int reported = 0;                   // TransitEnded events that changed the floor
  int matched = 0;                    // true transits with an overlapping reported change
  int missed = 0;                     // true transits without one
  int spurious = 0;                   // reported changes without a true transit
  int wrong_floor = 0;                // matched, but the floor reached is not the true one
  int mode_correct = 0;               // matched with the right elevator/stairs mode
  double height_rmse = 0.0;           // over matched transits, m
  std::vector<std::string> problems;  // one line per miss, spurious or wrong floor
  bool exact() const { return missed == 0 && spurious == 0 && wrong_floor == 0; }
};

// `events` are one robot's events (others are ignored) in order; `truth` that robot's
// transits. The detector's start floor is identified with the truth's first from_floor;
// each floor id the detector creates is identified with the true floor it first reached.
// A reported change matches a true transit when their intervals overlap within `slack`.
FloorComparison compareWithTruth(const std::vector<floor::FloorEvent>& events,
                                 const std::vector<TrueTransit>& truth, double slack = 10.0);

}  // namespace storey::eval
