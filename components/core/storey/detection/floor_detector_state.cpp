// FloorDetector's state across restarts: what it knows of the floors, saved and resumed.
#include <yaml-cpp/yaml.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <stdexcept>

#include "storey/common/config.h"
#include "storey/common/log.h"
#include "storey/detection/floor_detector.h"

namespace storey::detection {

using common::str;

FloorDetectorState FloorDetector::state() const {
  FloorDetectorState s;
  s.floors = floors_;
  s.current_floor = current_floor_;
  s.height_offset = height_offset_;
  s.offset_stddev = offset_stddev_;
  s.in_transit = state_ == State::kTransit && !silent_transit_;
  s.onset = onset_;
  s.saved_at = last_pressure_stamp_ > -1e299 ? last_pressure_stamp_ : 0.0;
  s.pending_identity = pending_;
  if (resume_pending_) {  // nothing processed since resume(): still the resumed state
    FloorDetectorState r = resumed_;
    r.floors = floors_;
    r.current_floor = current_floor_;
    r.pending_identity = pending_;
    return r;
  }
  if (state_ == State::kOnFloor) {
    if (!filtered_.empty()) {
      const double newest = filtered_.back().t;
      const Window w = filteredWindow(newest - options_.transit.reference_window, newest);
      s.reference_valid = w.count >= 3;
      s.reference_height = w.mean;
      s.reference_stddev = w.stddev;
    }
  } else {
    s.reference_valid = true;  // the height before the motion (or the gap)
    s.reference_height = start_height_;
    s.reference_stddev = start_height_stddev_;
  }
  return s;
}

namespace {
// Throws std::invalid_argument for a state no detector could go on from.
void checkFloorDetectorState(const FloorDetectorState& state) {
  auto bad = [](const std::string& why) {
    throw std::invalid_argument("floor detector state: " + why);
  };
  if (state.floors.empty()) bad("no floors");
  for (std::size_t i = 0; i < state.floors.size(); ++i) {
    if (state.floors[i].id != static_cast<int>(i)) bad("floor ids must be 0, 1, ... in order");
    if (!std::isfinite(state.floors[i].height))
      bad("floor " + std::to_string(i) + " has a non-finite height");
  }
  if (state.current_floor < 0 || state.current_floor >= static_cast<int>(state.floors.size()))
    bad("current floor " + std::to_string(state.current_floor) + " is not a floor");
  for (double v : {state.height_offset, state.offset_stddev, state.onset, state.reference_height,
                   state.reference_stddev, state.saved_at})
    if (!std::isfinite(v)) bad("non-finite value");
  if (const auto& p = state.pending_identity) {
    const int n = static_cast<int>(state.floors.size());
    if (p->chosen < 0 || p->chosen >= n) bad("pending identity: the chosen floor is not a floor");
    for (const int c : p->candidates)
      if (c < 0 || c >= n) bad("pending identity: candidate " + std::to_string(c) + " is not a floor");
    // A floor the arrival created is the last one; a new floor it may name comes next.
    if (p->created && p->chosen != n - 1) bad("pending identity: a created floor must be the last");
    if (p->new_floor_id >= 0 && p->new_floor_id != (p->created ? n - 1 : n))
      bad("pending identity: the new floor's id does not follow the floors");
    if (!std::isfinite(p->ride_end) || !std::isfinite(p->arrival) ||
        !std::isfinite(p->chosen_height_before))
      bad("pending identity: non-finite value");
  }
}
}  // namespace

void FloorDetector::resume(const FloorDetectorState& state, double max_resume_gap) {
  checkFloorDetectorState(state);
  floors_ = state.floors;
  current_floor_ = state.current_floor;
  height_offset_ = state.height_offset;
  offset_stddev_ = state.offset_stddev;
  state_ = State::kOnFloor;
  pending_ = state.pending_identity;
  resumed_ = state;
  max_resume_gap_ = max_resume_gap;
  resume_pending_ = true;
  // IMU heights are relative: they go on from the reference (a ride made while the
  // detector was stopped is not seen).
  if (!options_.sensors.barometer && state.reference_valid) {
    imu_height_.setHeight(state.reference_height);
  }
}

// At the first pressure sample after resume(): compare what comes with the saved
// reference, as after a gap in the barometer.
void FloorDetector::applyResume(double now) {
  resume_pending_ = false;
  const FloorDetectorState& r = resumed_;
  const double stopped = now - r.saved_at;
  if (r.in_transit || (r.reference_valid && stopped <= max_resume_gap_)) {
    if (stopped > max_resume_gap_)
      common::logWarn(str("floor_detector: resumed in a ride after ", stopped,
                          " s; the weather may have moved the barometer since"));
    state_ = State::kTransit;
    silent_transit_ = !r.in_transit;
    start_height_ = r.reference_height;
    start_height_stddev_ = r.reference_stddev;
    onset_ = r.in_transit ? r.onset : r.saved_at;
    quiet_since_ = -1.0;
    peak_speed_ = 0.0;
    transit_velocity_.clear();
  } else {
    common::logWarn(str("floor_detector: resumed after ", stopped,
                        " s without a usable barometric reference; "
                        "the robot is taken to be on floor ",
                        floors_[current_floor_].id));
  }
  common::logInfo(str("floor_detector: resumed on floor ", floors_[current_floor_].id,
                      r.in_transit ? " (in a ride)" : "", " after ", stopped, " s"));
}

void writeFloorDetectorState(const std::string& path, const FloorDetectorState& s) {
  YAML::Emitter out;
  out.SetDoublePrecision(17);
  out << YAML::BeginMap;
  out << YAML::Key << "current_floor" << YAML::Value << s.current_floor;
  out << YAML::Key << "height_offset" << YAML::Value << s.height_offset;
  out << YAML::Key << "offset_stddev" << YAML::Value << s.offset_stddev;
  out << YAML::Key << "in_transit" << YAML::Value << s.in_transit;
  out << YAML::Key << "onset" << YAML::Value << s.onset;
  out << YAML::Key << "reference_valid" << YAML::Value << s.reference_valid;
  out << YAML::Key << "reference_height" << YAML::Value << s.reference_height;
  out << YAML::Key << "reference_stddev" << YAML::Value << s.reference_stddev;
  out << YAML::Key << "saved_at" << YAML::Value << s.saved_at;
  out << YAML::Key << "floors" << YAML::Value << YAML::BeginSeq;
  for (const auto& f : s.floors) {
    out << YAML::Flow << YAML::BeginMap << YAML::Key << "id" << YAML::Value << f.id << YAML::Key
        << "height" << YAML::Value << f.height << YAML::Key << "arrivals" << YAML::Value
        << f.arrivals << YAML::Key << "configured" << YAML::Value << f.configured << YAML::EndMap;
  }
  out << YAML::EndSeq;
  if (const auto& p = s.pending_identity) {
    out << YAML::Key << "pending_identity" << YAML::Value << YAML::BeginMap;
    out << YAML::Key << "ride_end" << YAML::Value << p->ride_end;
    out << YAML::Key << "chosen" << YAML::Value << p->chosen;
    out << YAML::Key << "created" << YAML::Value << p->created;
    out << YAML::Key << "counted" << YAML::Value << p->counted;
    out << YAML::Key << "chosen_height_before" << YAML::Value << p->chosen_height_before;
    out << YAML::Key << "arrival" << YAML::Value << p->arrival;
    out << YAML::Key << "candidates" << YAML::Value << YAML::Flow << p->candidates;
    out << YAML::Key << "new_floor_id" << YAML::Value << p->new_floor_id;
    out << YAML::EndMap;
  }
  out << YAML::EndMap;
  const std::string tmp = path + ".tmp";
  {
    std::ofstream file(tmp);
    file << "# floor_detector state (written by the floor_detector component; read on restart)\n"
         << out.c_str() << "\n";
    if (!file) throw std::runtime_error(tmp + ": cannot write the floor detector state");
  }
  if (std::rename(tmp.c_str(), path.c_str()) != 0)
    throw std::runtime_error(path + ": cannot replace the floor detector state");
}

FloorDetectorState readFloorDetectorState(const std::string& path) {
  const common::ConfigNode node = common::ConfigNode::loadFile(path);
  FloorDetectorState s;
  s.current_floor = node.getInt("current_floor", 0, 100000);
  s.height_offset = node.getDouble("height_offset");
  s.offset_stddev = node.getDouble("offset_stddev", 0.0);
  s.in_transit = node.get<bool>("in_transit");
  s.onset = node.getDouble("onset");
  s.reference_valid = node.get<bool>("reference_valid");
  s.reference_height = node.getDouble("reference_height");
  s.reference_stddev = node.getDouble("reference_stddev", 0.0);
  s.saved_at = node.getDouble("saved_at");
  for (const auto& f : node.sequence("floors")) {
    Floor floor;
    floor.id = f.getInt("id", 0, 100000);
    floor.height = f.getDouble("height", -1e4, 1e4);
    floor.arrivals = f.getInt("arrivals", 0, std::numeric_limits<int>::max());
    floor.configured = f.get<bool>("configured");
    f.finish();
    s.floors.push_back(floor);
  }
  if (node.has("pending_identity")) {
    const common::ConfigNode p = node.child("pending_identity");
    PendingIdentity pending;
    pending.ride_end = p.getDouble("ride_end");
    pending.chosen = p.getInt("chosen", 0, 100000);
    pending.created = p.get<bool>("created");
    pending.counted = p.get<bool>("counted");
    pending.chosen_height_before = p.getDouble("chosen_height_before");
    pending.arrival = p.getDouble("arrival");
    for (const auto& c : p.sequence("candidates")) pending.candidates.push_back(c.as<int>());
    pending.new_floor_id = p.getInt("new_floor_id", -1, 100000);
    p.finish();
    s.pending_identity = pending;
  }
  node.finish();
  if (s.current_floor >= static_cast<int>(s.floors.size()))
    node.fail("current_floor", "is not one of the floors");
  try {
    checkFloorDetectorState(s);  // the checks resume() makes
  } catch (const std::invalid_argument& e) {
    node.fail("floors", e.what());
  }
  return s;
}

}  // namespace storey::detection
