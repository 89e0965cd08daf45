// Floor identity on arrival: which floors an arrival's height allows, the wait for the
// floor mapper's answer, and what the answer changes.
#include <algorithm>
#include <cmath>
#include <limits>

#include "storey/common/log.h"
#include "storey/detection/floor_detector.h"

namespace storey::detection {

using common::str;

void FloorDetector::identityCandidates(double arrival, double stddev, int chosen, bool created,
                                       bool changed, double chosen_height_before, FloorEvent& ev) {
  const auto& f = options_.floors;
  const std::size_t known_count = created ? floors_.size() - 1 : floors_.size();
  double lowest = arrival, highest = arrival;
  for (std::size_t i = 0; i < known_count; ++i) {
    lowest = std::min(lowest, floors_[i].height);
    highest = std::max(highest, floors_[i].height);
  }
  // An unknown change (a gap in the heights) reaches every floor and one beyond either end.
  double reach = kIdentitySigmas * stddev;
  if (!(reach > 0.0)) return;
  reach = std::min(reach, highest - lowest + 2.0 * f.storey_height);
  std::vector<std::pair<double, int>> known;
  for (std::size_t i = 0; i < known_count; ++i) {
    const double d = std::abs(floors_[i].height - arrival);
    if (d <= f.match_tolerance + reach) known.emplace_back(d, static_cast<int>(i));
  }
  std::sort(known.begin(), known.end());
  // A floor never seen: some height within reach that no known floor matches, as far from
  // the floor left as a floor change goes.
  const double from = floors_[static_cast<std::size_t>(current_floor_)].height;
  const double step = 0.1 * f.match_tolerance;
  const int steps = std::min(100000, static_cast<int>(std::ceil(2.0 * reach / step)));
  bool may_be_new = false;
  for (int k = 0; k <= steps && !may_be_new; ++k) {
    const double y = arrival - reach + 2.0 * reach * k / std::max(steps, 1);
    double nearest = std::numeric_limits<double>::infinity();
    for (std::size_t i = 0; i < known_count; ++i)
      nearest = std::min(nearest, std::abs(floors_[i].height - y));
    may_be_new = nearest > f.match_tolerance &&
                 std::abs(y - from) >= f.min_change_fraction * f.storey_height;
  }
  if (known.size() + (may_be_new ? 1 : 0) < 2) return;
  ++stats_.unsure_arrivals;
  for (const auto& k : known) ev.candidate_floors.push_back(floors_[k.second].id);
  ev.new_floor_id = may_be_new ? (created ? chosen : static_cast<int>(floors_.size())) : -1;
  ev.new_floor_height = arrival;
  PendingIdentity p;
  p.ride_end = quiet_since_;
  p.chosen = chosen;
  p.created = created;
  p.counted = changed;
  p.chosen_height_before = chosen_height_before;
  p.arrival = arrival;
  p.candidates = ev.candidate_floors;
  p.new_floor_id = ev.new_floor_id;
  pending_ = p;
}

bool FloorDetector::setFloorIdentity(const FloorIdentity& identity) {
  if (!pending_ || std::abs(identity.ride_end - pending_->ride_end) > 1e-6) {
    common::logWarn(str("floor_detector: floor identity for the ride that ended at t=",
                        identity.ride_end, ": no unsure arrival waits for it; ignored"));
    return false;
  }
  const PendingIdentity p = *pending_;
  const bool known =
      std::find(p.candidates.begin(), p.candidates.end(), identity.floor_id) != p.candidates.end();
  const bool valid = known || identity.floor_id == p.chosen ||
                     (p.new_floor_id >= 0 && identity.floor_id == p.new_floor_id);
  pending_.reset();
  if (!valid) {
    common::logWarn(str("floor_detector: floor identity ", identity.floor_id,
                        " for the ride that ended at t=", identity.ride_end,
                        " is none of its candidates; the height's choice, floor ", p.chosen,
                        ", stands"));
    ++stats_.identities_not_answered;
  } else {
    applyIdentity(p, identity.floor_id);
    // Found in the floor's map: on that floor, whatever the height had gathered.
    if (identity.localized) height_offset_ = offset_stddev_ = 0.0;
  }
  if (holding_) releaseHold();
  return valid;
}

void FloorDetector::applyIdentity(const PendingIdentity& p, int floor_id) {
  if (floor_id == p.chosen) return;
  ++stats_.identities_changed;
  // Undo the arrival at the height's choice: a floor it created was the last one made.
  if (p.created) {
    floors_.pop_back();
  } else {
    Floor& chosen = floors_[static_cast<std::size_t>(p.chosen)];
    chosen.height = p.chosen_height_before;
    if (p.counted && chosen.arrivals > 0) --chosen.arrivals;
  }
  if (floor_id == p.new_floor_id && floor_id == static_cast<int>(floors_.size())) {
    floors_.push_back(Floor{floor_id, p.arrival, 1, false});
  } else {
    ++floors_[static_cast<std::size_t>(floor_id)].arrivals;
  }
  current_floor_ = floor_id;
  height_offset_ = 0.0;
  offset_stddev_ = 0.0;
  common::logInfo(str("floor_detector: the ride that ended at t=", p.ride_end, " reached floor ",
                      floor_id, " (the height chose ", p.chosen, ")"));
}

void FloorDetector::holdForIdentity() {
  holding_ = true;
  hold_decided_at_ = last_pressure_stamp_;
  FloorEvent w;
  w.type = FloorEventType::kAwaitingIdentity;
  w.stamp = pending_->ride_end;
  w.from_floor = floors_[static_cast<std::size_t>(current_floor_)].id;
  events_.push_back(w);
  common::logInfo(str("floor_detector: a ride begins at t=", onset_,
                      "; waiting for the identity of the floor ",
                      "reached at t=", pending_->ride_end));
}

template <class Sample>
FloorDetector::QueuedInput FloorDetector::QueuedInput::make(Kind kind, const Sample& s,
                                                            Sample QueuedInput::*field) {
  QueuedInput q{kind, s.stamp};
  q.*field = s;
  return q;
}
FloorDetector::QueuedInput FloorDetector::QueuedInput::of(const sensor::PressureSample& s) {
  return make(Kind::kPressure, s, &QueuedInput::pressure);
}
FloorDetector::QueuedInput FloorDetector::QueuedInput::of(const sensor::ImuSample& s) {
  return make(Kind::kImu, s, &QueuedInput::imu);
}
FloorDetector::QueuedInput FloorDetector::QueuedInput::of(const sensor::OdometrySample& s) {
  return make(Kind::kOdometry, s, &QueuedInput::odometry);
}
FloorDetector::QueuedInput FloorDetector::QueuedInput::of(const sensor::LaserScan& s) {
  return make(Kind::kScan, s, &QueuedInput::scan);
}
FloorDetector::QueuedInput FloorDetector::QueuedInput::ofHeight(double t, double height) {
  QueuedInput q{Kind::kHeight, t};
  q.height = height;
  return q;
}

bool FloorDetector::queueIfHolding(QueuedInput input) {
  const double stamp = input.stamp;
  queue_.push_back(std::move(input));
  // A mapper that does not answer (not running) must not stop floor detection.
  if (std::isfinite(stamp) && stamp - hold_decided_at_ > identity_wait_) {
    common::logWarn(
        str("floor_detector: no floor identity for the ride that ended at t=", pending_->ride_end,
            " within ", identity_wait_, " s; the height's choice, floor ", pending_->chosen,
            ", stands (is the floor_mapper running?)"));
    ++stats_.identities_not_answered;
    pending_.reset();
    releaseHold();
  }
  return true;
}

void FloorDetector::releaseHold() {
  holding_ = false;
  FloorEvent s;
  s.type = FloorEventType::kTransitStarted;
  s.stamp = s.start_stamp = onset_;
  s.decided_at = hold_decided_at_;
  s.from_floor = floors_[static_cast<std::size_t>(current_floor_)].id;
  s.from_height = floors_[static_cast<std::size_t>(current_floor_)].height;
  s.floor_id = s.from_floor;
  s.floor_height = s.from_height;
  events_.push_back(s);
  common::logInfo(
      str("floor_detector: transit started at t=", onset_, " from floor ", s.from_floor));
  std::deque<QueuedInput> queued;
  queued.swap(queue_);
  while (!queued.empty() && !holding_) {
    QueuedInput q = std::move(queued.front());
    queued.pop_front();
    switch (q.kind) {
      case QueuedInput::Kind::kPressure:
        addPressure(q.pressure);
        break;
      case QueuedInput::Kind::kImu:
        addImu(q.imu);
        break;
      case QueuedInput::Kind::kOdometry:
        addOdometry(q.odometry);
        break;
      case QueuedInput::Kind::kScan:
        addScan(q.scan);
        break;
      case QueuedInput::Kind::kHeight:
        addHeight(q.stamp, q.height);
        break;
    }
  }
  // Held again (another unsure arrival): what the last input queued comes first.
  for (auto& q : queued) queue_.push_back(std::move(q));
}

}  // namespace storey::detection
