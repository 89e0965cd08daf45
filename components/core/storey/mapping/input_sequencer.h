// The floor mapper's inputs arrive on three independent topics (scans, odometry, floor
// events), so how they interleave depends on delivery timing. InputSequencer puts them in
// one order that depends on their stamps alone, so that the same recording gives the same
// floor graphs in one process, split over machines, or after a component restart:
// - a scan waits until odometry at or after its stamp has arrived (its pose is
//   interpolated, not taken from whatever odometry came first);
// - a floor event applies after every scan stamped up to its decided_at (when the
//   detector decided it) and before every later scan; so it waits until a later scan has
//   arrived, and a scan waits until the detector has reported progress past its stamp.
// Bounded waits keep a dead or absent detector or odometry source from stopping mapping
// (then the order is by arrival again, and it is logged).
#pragma once

#include <cstddef>
#include <deque>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "storey/common/config.h"
#include "storey/common/shipped_config.h"
#include "storey/floor/floor_event.h"
#include "storey/geometry/pose2.h"
#include "storey/sensor/laser_scan.h"

namespace storey::mapping {

struct InputSequencerOptions {
  // s: a scan needs odometry this close to its stamp
  double max_odometry_gap = shipped::floor_mapper::max_odometry_gap;
  // hold scans until the detector's progress passes them
  bool wait_for_floor_detector = shipped::floor_mapper::wait_for_floor_detector;
  // s of scans held at most for the detector
  double max_floor_detector_lag = shipped::floor_mapper::max_floor_detector_lag;
  std::size_t max_scans_waiting_for_odometry = 600;
};

// The floor_mapper's input keys (max_odometry_gap, wait_for_floor_detector,
// max_floor_detector_lag) at the top level of its file, beside its other keys: `node` is not
// finished here, its reader does that.
InputSequencerOptions readInputSequencerOptions(const common::ConfigNode& node);

struct InputSequencerStats {
  std::size_t scans = 0;                   // passed on with their odometry
  std::size_t scans_without_odometry = 0;  // dropped: no odometry within max_odometry_gap
  std::size_t floor_events = 0;            // transit started / ended passed on
  std::size_t released_by_lag = 0;         // scans passed on without the detector's progress
  std::size_t already_mapped = 0;  // scans (after resumeAfter) and events taken before, skipped
};

class InputSequencer {
 public:
  using ScanHandler = std::function<void(const sensor::LaserScan&, const geometry::Pose2& odometry)>;
  using EventHandler = std::function<void(const floor::FloorEvent&)>;

  InputSequencer(InputSequencerOptions options, ScanHandler on_scan, EventHandler on_event,
                 std::string name = "floor_mapper");

  // Each returns after passing on whatever became ready. Samples out of order on their
  // own stream (or with non-finite stamps) are dropped.
  void addOdometry(const sensor::OdometrySample& sample);
  void addScan(sensor::LaserScan scan);
  // TransitStarted, TransitEnded or Progress (which only moves the detector's clock).
  void addFloorEvent(const floor::FloorEvent& event);
  // End of input: everything still waiting is passed on in the same order.
  void flush();
  // While paused, inputs are only queued (a component not yet active); unpausing passes
  // on what became ready.
  void setPaused(bool paused);
  // After a restart that replayed an input log: scans up to `last_scan` and events decided
  // up to `last_event` were mapped already; when they arrive again (a durable topic's
  // history) they are skipped.
  void resumeAfter(double last_scan, double last_event);

  std::size_t scansWaiting() const { return scans_.size(); }
  std::size_t eventsWaiting() const { return events_.size(); }
  double detectorProgress() const { return detector_progress_; }
  const InputSequencerStats& stats() const { return stats_; }

 private:
  void process(bool all);
  void passOn(bool all);
  bool odometryAt(double stamp, geometry::Pose2& odometry) const;
  void trimOdometry();

  InputSequencerOptions options_;
  ScanHandler on_scan_;
  EventHandler on_event_;
  std::string name_;
  std::deque<sensor::OdometrySample> odometry_;
  std::deque<sensor::LaserScan> scans_;
  std::deque<floor::FloorEvent> events_;
  double detector_progress_ = -1e300;  // the detector has decided everything up to here
  double newest_scan_ = -1e300;        // stamp of the newest scan received
  double resume_scan_ = -1e300;        // scans up to here were mapped already
  double last_event_ = -1e300;  // decided_at of the last event taken
  int last_event_type_ = -1;
  bool lag_reported_ = false;
  bool paused_ = false;
  InputSequencerStats stats_;
};

// Recorded scans paired with odometry as the InputSequencer pairs them live: interpolated
// at each scan's stamp (options.max_odometry_gap). Both in stamp order. Empty for a scan with
// no sample near enough (the sequencer drops those).
std::vector<std::optional<geometry::Pose2>> odometryAtScans(
    const std::vector<sensor::LaserScan>& scans,
    const std::vector<sensor::OdometrySample>& odometry, InputSequencerOptions options = {});

}  // namespace storey::mapping
