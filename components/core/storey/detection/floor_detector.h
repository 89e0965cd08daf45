// Floor-change detection for one robot: barometric height (hypsometric equation) with a
// spike-rejecting Hampel (median) filter and a least-squares vertical velocity; a ride or stair
// climb is sustained vertical motion, weather drift is not. IMU, odometry and scans, each
// optional, corroborate a ride and tell an elevator from stairs. Arrival heights are
// matched to known floors (seen before, or from the building's configuration).
//
// Pressure samples drive the clock; on a robot without a barometer (sensors.barometer
// false) the heights ImuHeight derives from the IMU and odometry take their place. Feed
// every stream in time order per stream (streams may interleave with a lag of a few
// seconds). No DDS here: see components/floor_detector.
#pragma once

#include <deque>
#include <optional>
#include <string>
#include <vector>

#include "storey/detection/barometer.h"
#include "storey/detection/floor_detector_options.h"
#include "storey/detection/imu_height.h"
#include "storey/floor/floor_event.h"
#include "storey/sensor/laser_scan.h"

namespace storey::detection {

// The events this detector produces are the floor module's (storey/floor/floor_event.h):
// the floor mapper reads them without depending on the detector.
using floor::FloorEvent;
using floor::FloorEventType;
using floor::FloorIdentity;
using floor::TransitMode;
using floor::transitModeName;

struct Floor {
  int id = 0;
  double height = 0.0;  // m, building frame
  int arrivals = 0;     // rides that ended here
  // Height kept fixed: from the building's configuration, or the starting floor (datum).
  bool configured = false;
};

// An arrival the height did not decide, waiting for the floor mapper's answer
// (FloorDetector::setFloorIdentity).
struct PendingIdentity {
  double ride_end = 0.0;
  int chosen = 0;                     // the floor the height chose
  bool created = false;               // ... created by this arrival
  bool counted = false;               // ... and counted as an arrival there
  double chosen_height_before = 0.0;  // its height before this arrival's running mean
  double arrival = 0.0;               // m, height reached
  std::vector<int> candidates;
  int new_floor_id = -1;
};

// What a restarted detector needs to go on where it stopped (FloorDetector::state/resume):
// the floors, where the robot is, the barometric reference it compares against, and an
// arrival still waiting for its identity (the mapper's answer may come after the restart).
struct FloorDetectorState {
  std::vector<Floor> floors;
  int current_floor = 0;
  double height_offset = 0.0;  // robot above its floor's height, m
  double offset_stddev = 0.0;
  bool in_transit = false;  // a TransitStarted was sent and its TransitEnded was not
  double onset = 0.0;       // s: start of that ride
  // Filtered barometric height (hypsometric, absolute) that the current floor (plus
  // offset) or, in transit, the floor left corresponds to; invalid before enough samples.
  bool reference_valid = false;
  double reference_height = 0.0;
  double reference_stddev = 0.0;
  double saved_at = 0.0;  // s: last pressure sample processed
  std::optional<PendingIdentity> pending_identity;
};

// Written atomically (a temporary file renamed over it). Reading is strict: an error names
// the file and the key.
void writeFloorDetectorState(const std::string& path, const FloorDetectorState& state);
FloorDetectorState readFloorDetectorState(const std::string& path);

struct FloorDetectorStats {
  std::size_t pressure_samples = 0;
  std::size_t rejected_pressure = 0;  // NaN, out of range, out of order
  std::size_t rejected_other = 0;     // bad IMU / odometry / scan samples
  std::size_t gaps = 0;
  std::size_t cancelled_candidates = 0;  // vertical motion too short to be a ride
  std::size_t before_resume = 0;         // pressure samples not after the resumed state
  std::size_t unsure_arrivals = 0;       // TransitEnded events with candidate floors
  std::size_t identities_changed = 0;    // answers that named another floor than the height's
  std::size_t identities_not_answered = 0;  // unsure arrivals kept without an answer
};

class FloorDetector {
 public:
  explicit FloorDetector(const FloorDetectorOptions& options);

  // Each returns false (and logs, rate-limited) when the sample was rejected.
  bool addPressure(const sensor::PressureSample& sample);
  bool addImu(const sensor::ImuSample& sample);
  bool addOdometry(const sensor::OdometrySample& sample);
  bool addScan(const sensor::LaserScan& scan);

  // Events produced since the last call, oldest first.
  std::vector<FloorEvent> takeEvents();

  // Floor identity on arrival. An arrival the height alone does not decide (more than one
  // floor, known or new, within kIdentitySigmas standard deviations of the height change
  // and the match tolerance) goes out as a TransitEnded with candidate_floors; the floor
  // mapper localises the arriving scans in those floors' maps and answers. With
  // awaitIdentity(max_wait) the detector, before it confirms the next ride, stops and
  // queues its input (sending kAwaitingIdentity) until the answer comes, so the events it
  // sends do not depend on when the answer arrived; after `max_wait` seconds of queued
  // input (a mapper that is not running) it goes on with the height's choice. Without it
  // (the default: `storey floors`, no mapper) the height's choice stands.
  static constexpr double kIdentitySigmas = 3.0;
  void awaitIdentity(double max_wait) { identity_wait_ = max_wait; }
  // The mapper's answer. False (and logged) when no unsure arrival waits for it or the
  // floor is not one of its candidates. Queued input is processed before it returns.
  bool setFloorIdentity(const FloorIdentity& identity);
  bool awaitingIdentity() const { return pending_.has_value(); }
  bool holding() const { return holding_; }

  FloorDetectorState state() const;
  // Goes on from a saved state (a restarted detector). Pressure samples up to saved_at are
  // skipped. The first samples after it are compared with the saved reference, as after a
  // gap: a ride missed while stopped is reported (TransitStarted and TransitEnded), a ride
  // in progress ends with its TransitEnded; unless more than `max_resume_gap` seconds
  // passed (the weather moves the barometer), then the saved floor is kept as it is.
  // Throws std::invalid_argument for an inconsistent state.
  void resume(const FloorDetectorState& state, double max_resume_gap = 60.0);

  int currentFloor() const { return current_floor_; }
  // Stamp of the last pressure sample processed: every event decided up to it has been
  // returned by takeEvents() (or is waiting there).
  double processedUntil() const { return last_pressure_stamp_; }
  bool inTransit() const { return state_ == State::kTransit && !silent_transit_; }
  // Height estimate of the robot in the building frame (m); the current floor's height
  // plus the filtered barometric change since the floor's reference.
  double currentHeight() const;
  const std::vector<Floor>& floors() const { return floors_; }
  const FloorDetectorStats& stats() const { return stats_; }
  const FloorDetectorOptions& options() const { return options_; }

 private:
  enum class State { kOnFloor, kCandidate, kTransit };
  struct TimedValue {
    double t;
    double value;
  };
  struct OdomPoint {
    double t;
    double x, y;
  };
  struct Window {
    double mean = 0.0;
    double stddev = 0.0;
    std::size_t count = 0;
    double span = 0.0;
  };

  bool addHeight(double stamp, double height);  // the clock: a barometric or IMU height
  void processFiltered(double now);
  void onVelocity(double t_v, double v, double now);
  void beginCandidate(double t_v, double v);
  void confirmTransit();
  void maybeEndTransit(double t_v);
  void endTransit(int floor_index, bool changed, bool created, double end_height);
  void handleGap(double gap_start, double gap_end);
  Window filteredWindow(double from, double to) const;
  void trimHistories(double now);
  void rejectLog(const std::string& what, std::size_t& counter);

  // Corroboration evaluated over [start, end] at the end of a ride.
  struct Evidence {
    double log_odds = 0.0;
    double elevator_votes = 0.0;
    double stairs_votes = 0.0;
  };
  // Unsure arrivals (floor_detector_identity.cpp).
  // Fills the event's candidates when the arrival is unsure; remembers it as pending.
  void identityCandidates(double arrival, double stddev, int chosen, bool created, bool changed,
                          double chosen_height_before, FloorEvent& ev);
  void applyIdentity(const PendingIdentity& p, int floor_id);
  void holdForIdentity();
  // While holding, the input is queued in arrival order (a height: IMU heights already
  // taken when the hold began).
  struct QueuedInput {
    enum class Kind { kPressure, kImu, kOdometry, kScan, kHeight };
    QueuedInput(Kind k, double t) : kind(k), stamp(t) {}
    Kind kind;
    double stamp;
    sensor::PressureSample pressure;
    sensor::ImuSample imu;
    sensor::OdometrySample odometry;
    sensor::LaserScan scan;
    double height = 0.0;
    static QueuedInput of(const sensor::PressureSample& s);
    static QueuedInput of(const sensor::ImuSample& s);
    static QueuedInput of(const sensor::OdometrySample& s);
    static QueuedInput of(const sensor::LaserScan& s);
    static QueuedInput ofHeight(double t, double height);
    template <class Sample>
    static QueuedInput make(Kind kind, const Sample& s, Sample QueuedInput::*field);
  };
  bool queueIfHolding(QueuedInput input);
  void releaseHold();
  std::optional<PendingIdentity> pending_;
  double identity_wait_ = 0.0;  // s; 0: do not wait
  bool holding_ = false;
  double hold_decided_at_ = 0.0;  // stamp at which the next ride was confirmed
  std::deque<QueuedInput> queue_;

  void imuEvidence(double start, double end, Evidence& e) const;
  void odometryEvidence(double start, double end, Evidence& e) const;
  void scanEvidence(double start, double end, Evidence& e) const;
  double historySeconds() const;
  static constexpr std::size_t kMaxScansKept = 200;
  static constexpr std::size_t kMaxSamplesKept = 2000000;
  static constexpr double kScanLag = 1.0;  // s between the scans compared

  FloorDetectorOptions options_;
  std::vector<Floor> floors_;
  int current_floor_ = 0;  // index into floors_ (== id)
  std::vector<FloorEvent> events_;
  FloorDetectorStats stats_;

  // Heights from the IMU and odometry, for a robot without a barometer.
  ImuHeight imu_height_;
  void takeImuHeights();

  // Barometer filter.
  double last_pressure_stamp_ = -1e300;
  std::deque<TimedValue> raw_;       // raw heights within the median window
  std::deque<TimedValue> filtered_;  // Hampel-filtered heights (delayed by half the window)
  double last_velocity_ = 0.0;
  double window_height_ = 0.0;  // mean filtered height over the velocity window
  bool velocity_valid_ = false;

  // State machine.
  State state_ = State::kOnFloor;
  bool silent_transit_ = false;  // entered through a pressure gap: no TransitStarted yet
  double onset_ = 0.0;           // start of vertical motion (s)
  double start_height_ = 0.0;    // filtered barometric height before the motion
  double start_height_stddev_ = 0.0;
  double quiet_since_ = -1.0;     // velocity time at which the robot became quiet, or < 0
  double quiet_height_ = 0.0;     // window height when the robot became quiet
  double candidate_since_ = 0.0;  // velocity time at which the candidate began
  double candidate_sign_ = 0.0;
  double last_pressure_ = kReferencePressure;
  double peak_speed_ = 0.0;
  std::vector<TimedValue> transit_velocity_;  // baro vertical velocity during the ride

  // Corroborating streams (trimmed to a few seconds while on a floor).
  std::deque<TimedValue> imu_;  // |specific force|: gravity and the vertical acceleration
  std::deque<OdomPoint> odom_;
  std::deque<sensor::LaserScan> scans_;
  // Similarity of each scan to the one about a second before it (trimmed like imu_).
  std::deque<TimedValue> scan_similarity_;
  double height_offset_ = 0.0;  // robot above its floor's height (a ramp, a landing), m
  double offset_stddev_ = 0.0;
  bool resume_pending_ = false;
  FloorDetectorState resumed_;
  double max_resume_gap_ = 60.0;
  void applyResume(double now);
  double last_imu_stamp_ = -1e300;
  double last_odom_stamp_ = -1e300;
  double last_scan_stamp_ = -1e300;
};

}  // namespace storey::detection
