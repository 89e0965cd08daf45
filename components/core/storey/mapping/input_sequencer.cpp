#include "storey/mapping/input_sequencer.h"

#include <algorithm>
#include <cmath>
#include <utility>

#include "storey/common/log.h"

namespace storey::mapping {

using common::str;

InputSequencerOptions readInputSequencerOptions(const common::ConfigNode& node) {
  InputSequencerOptions o;
  o.max_odometry_gap = node.getDouble("max_odometry_gap", o.max_odometry_gap, 1e-3, 60.0);
  o.wait_for_floor_detector = node.get<bool>("wait_for_floor_detector", o.wait_for_floor_detector);
  o.max_floor_detector_lag =
      node.getDouble("max_floor_detector_lag", o.max_floor_detector_lag, 0.0, 3600.0);
  return o;
}

InputSequencer::InputSequencer(InputSequencerOptions options, ScanHandler on_scan, EventHandler on_event,
                               std::string name)
    : options_(options), on_scan_(std::move(on_scan)), on_event_(std::move(on_event)), name_(std::move(name)) {}

void InputSequencer::addOdometry(const sensor::OdometrySample& sample) {
  if (!std::isfinite(sample.stamp) || !sample.pose.isFinite()) return;
  if (!odometry_.empty() && sample.stamp < odometry_.back().stamp) return;  // out of order
  odometry_.push_back(sample);
  process(false);
}

void InputSequencer::addScan(sensor::LaserScan scan) {
  if (!std::isfinite(scan.stamp)) return;
  // An older scan than one already received: the mapper would refuse it anyway (time
  // going backwards), and ordering events against it is meaningless.
  if (scan.stamp <= resume_scan_) {
    ++stats_.already_mapped;
    return;
  }
  if (scan.stamp < newest_scan_) {
    common::logWarn(str(name_, ": scan at ", scan.stamp, " after one at ", newest_scan_, "; dropped"));
    return;
  }
  newest_scan_ = scan.stamp;
  scans_.push_back(std::move(scan));
  process(false);
}

void InputSequencer::addFloorEvent(const floor::FloorEvent& event) {
  if (!std::isfinite(event.decided_at)) return;
  detector_progress_ = std::max(detector_progress_, event.decided_at);
  if (event.type != floor::FloorEventType::kProgress) {
    // The detector decides events in order; one decided no later than the last taken was
    // taken already (sent again by a restarted detector, or logged before a restart).
    const int type = static_cast<int>(event.type);
    if (event.decided_at < last_event_ || (event.decided_at == last_event_ && type <= last_event_type_)) {
      ++stats_.already_mapped;
      return;
    }
    last_event_ = event.decided_at;
    last_event_type_ = type;
    events_.push_back(event);
  }
  process(false);
}

void InputSequencer::flush() { process(true); }

void InputSequencer::setPaused(bool paused) {
  paused_ = paused;
  process(false);
}

void InputSequencer::resumeAfter(double last_scan, double last_event) {
  resume_scan_ = last_scan;
  if (last_event > last_event_) {
    last_event_ = last_event;
    last_event_type_ = 1000;  // every event decided then was logged
  }
  newest_scan_ = std::max(newest_scan_, last_scan);
}

void InputSequencer::process(bool all) {
  if (paused_ && !all) return;
  passOn(all);
  trimOdometry();
}

void InputSequencer::passOn(bool all) {
  while (!scans_.empty() || !events_.empty()) {
    // An event goes first when every scan up to its decision has been passed on, and it is
    // known that no more are coming (a later scan has arrived).
    if (!events_.empty()) {
      const double decided = events_.front().decided_at;
      const bool earlier_scans_done = scans_.empty() || scans_.front().stamp > decided;
      if (earlier_scans_done && (all || newest_scan_ > decided)) {
        const floor::FloorEvent event = events_.front();
        events_.pop_front();
        ++stats_.floor_events;
        on_event_(event);
        continue;
      }
      if (earlier_scans_done) return;  // waiting for a scan after it
    }
    if (scans_.empty()) return;
    const sensor::LaserScan& scan = scans_.front();
    if (!all) {
      const bool odometry_after = !odometry_.empty() && odometry_.back().stamp >= scan.stamp;
      if (!odometry_after && scans_.size() <= options_.max_scans_waiting_for_odometry) return;
      if (options_.wait_for_floor_detector && scan.stamp > detector_progress_) {
        if (newest_scan_ - scan.stamp <= options_.max_floor_detector_lag) return;
        ++stats_.released_by_lag;
        if (!lag_reported_) {
          common::logWarn(str(name_, ": no floor detector progress past t=", scan.stamp, " for ",
                              options_.max_floor_detector_lag,
                              " s of scans; mapping on without it (is the floor_detector running?)"));
          lag_reported_ = true;
        }
      } else if (scan.stamp <= detector_progress_) {
        lag_reported_ = false;
      }
    }
    geometry::Pose2 odometry;
    if (odometryAt(scan.stamp, odometry)) {
      ++stats_.scans;
      on_scan_(scan, odometry);
    } else {
      ++stats_.scans_without_odometry;
      common::logDebug(str(name_, ": no odometry near the scan at ", scan.stamp, "; scan dropped"));
    }
    scans_.pop_front();
  }
}

// Odometry at the stamp: interpolated between the samples around it, or the nearest one
// within max_odometry_gap.
bool InputSequencer::odometryAt(double stamp, geometry::Pose2& odometry) const {
  const sensor::OdometrySample* before = nullptr;
  const sensor::OdometrySample* after = nullptr;
  for (const auto& s : odometry_) {
    if (s.stamp <= stamp) before = &s;
    else if (!after) after = &s;
  }
  const double gap = options_.max_odometry_gap;
  if (before && after && after->stamp - before->stamp <= gap) {
    odometry = geometry::interpolate(before->pose, after->pose, (stamp - before->stamp) / (after->stamp - before->stamp));
  } else if (before && stamp - before->stamp <= gap) {
    odometry = before->pose;
  } else if (after && after->stamp - stamp <= gap) {
    odometry = after->pose;
  } else {
    return false;
  }
  return true;
}

// Kept from just before the next scan to come (odometry may run ahead of scans, even by
// seconds after a stall), and at most kMaxOdometryKept back from the newest sample.
void InputSequencer::trimOdometry() {
  constexpr double kMaxOdometryKept = 300.0;  // s
  if (odometry_.empty()) return;
  const double next_scan = scans_.empty() ? newest_scan_ : scans_.front().stamp;
  const double keep_from =
      std::max(next_scan - options_.max_odometry_gap - 1.0, odometry_.back().stamp - kMaxOdometryKept);
  while (odometry_.size() > 2 && odometry_.front().stamp < keep_from) odometry_.pop_front();
}

std::vector<std::optional<geometry::Pose2>> odometryAtScans(
    const std::vector<sensor::LaserScan>& scans,
    const std::vector<sensor::OdometrySample>& odometry, InputSequencerOptions options) {
  std::vector<std::optional<geometry::Pose2>> paired(scans.size());
  std::size_t next = 0;  // the first scan not yet passed on or dropped
  options.wait_for_floor_detector = false;
  InputSequencer sequencer(
      options,
      [&](const sensor::LaserScan& scan, const geometry::Pose2& pose) {
        // Scans come out in input order; those dropped before this one have earlier stamps.
        while (next < scans.size() && scans[next].stamp < scan.stamp) ++next;
        if (next < scans.size()) paired[next++] = pose;
      },
      [](const floor::FloorEvent&) {}, "odometryAtScans");
  // Fed merged by stamp, as they would arrive live (odometry first at equal stamps).
  std::size_t o = 0;
  for (const auto& scan : scans) {
    while (o < odometry.size() && odometry[o].stamp <= scan.stamp)
      sequencer.addOdometry(odometry[o++]);
    sequencer.addScan(scan);
  }
  while (o < odometry.size()) sequencer.addOdometry(odometry[o++]);
  sequencer.flush();
  return paired;
}

}  // namespace storey::mapping
