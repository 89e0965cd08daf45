#include "storey/detection/floor_detector.h"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <stdexcept>

#include "storey/common/config.h"
#include "storey/common/log.h"

namespace storey::detection {

using common::str;

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

constexpr double kHampelSigmas = 3.0;

double medianOf(std::vector<double> values) {
  const std::size_t mid = values.size() / 2;
  std::nth_element(values.begin(), values.begin() + mid, values.end());
  double median = values[mid];
  if (values.size() % 2 == 0) {
    median = 0.5 * (median + *std::max_element(values.begin(), values.begin() + mid));
  }
  return median;
}

double sign(double v) { return v > 0.0 ? 1.0 : (v < 0.0 ? -1.0 : 0.0); }

double sigmoid(double x) { return 1.0 / (1.0 + std::exp(-x)); }

}  // namespace

FloorDetector::FloorDetector(const FloorDetectorOptions& options)
    : options_(options), imu_height_(options.imu) {
  if (options_.floors.heights.empty()) {
    floors_.push_back(Floor{0, 0.0, 1, true});
    current_floor_ = 0;
  } else {
    for (std::size_t i = 0; i < options_.floors.heights.size(); ++i) {
      floors_.push_back(Floor{static_cast<int>(i), options_.floors.heights[i], 0, true});
    }
    current_floor_ = options_.floors.initial_floor;
    floors_[current_floor_].arrivals = 1;
  }
}

double FloorDetector::historySeconds() const {
  const auto& b = options_.barometer;
  const auto& t = options_.transit;
  return b.median_window + b.velocity_window + t.reference_window +
         std::max(t.min_duration, t.new_floor_settle_time) + 5.0;
}

std::vector<FloorEvent> FloorDetector::takeEvents() {
  std::vector<FloorEvent> out;
  out.swap(events_);
  return out;
}

double FloorDetector::currentHeight() const {
  const double floor_height = floors_[current_floor_].height + height_offset_;
  if (state_ == State::kOnFloor || !velocity_valid_) return floor_height;
  return floor_height + window_height_ - start_height_;
}

void FloorDetector::rejectLog(const std::string& what, std::size_t& counter) {
  ++counter;
  // The first few and then every thousandth: a broken sensor must not flood the log.
  if (counter <= 10 || counter % 1000 == 0) {
    common::logWarn(str("floor_detector: rejected ", what, " (", counter, " so far)"));
  }
}

bool FloorDetector::addPressure(const sensor::PressureSample& sample) {
  const auto& b = options_.barometer;
  if (holding_) return queueIfHolding(QueuedInput::of(sample));
  if (!options_.sensors.barometer) {
    rejectLog("pressure sample: sensors.barometer is false", stats_.rejected_pressure);
    return false;
  }
  if (!std::isfinite(sample.stamp)) {
    rejectLog("pressure sample with a non-finite stamp", stats_.rejected_pressure);
    return false;
  }
  if (resume_pending_ && sample.stamp <= resumed_.saved_at) {
    ++stats_.before_resume;  // processed before the restart (a durable topic sends it again)
    return false;
  }
  if (!std::isfinite(sample.pascal) || sample.pascal < b.min_pressure ||
      sample.pascal > b.max_pressure) {
    rejectLog(str("pressure ", sample.pascal, " Pa at t=", sample.stamp, " (valid range ",
                  b.min_pressure, "..", b.max_pressure, ")"),
              stats_.rejected_pressure);
    return false;
  }
  if (sample.stamp <= last_pressure_stamp_) {
    rejectLog(str("pressure sample at t=", sample.stamp, " not after t=", last_pressure_stamp_),
              stats_.rejected_pressure);
    return false;
  }
  last_pressure_ = sample.pascal;
  return addHeight(sample.stamp, pressureHeight(sample.pascal, b.temperature_kelvin));
}

void FloorDetector::takeImuHeights() {
  for (const auto& h : imu_height_.take()) {
    if (resume_pending_ && h.t <= resumed_.saved_at) {
      ++stats_.before_resume;
      continue;
    }
    if (holding_) {  // the hold began with an earlier height of this batch
      queueIfHolding(QueuedInput::ofHeight(h.t, h.height));
      continue;
    }
    addHeight(h.t, h.height);
  }
}

bool FloorDetector::addHeight(double stamp, double h) {
  const auto& b = options_.barometer;
  ++stats_.pressure_samples;
  const std::size_t first_new_event = events_.size();
  if (resume_pending_) applyResume(stamp);
  if (stats_.pressure_samples > 1 && stamp - last_pressure_stamp_ > b.max_gap) {
    handleGap(last_pressure_stamp_, stamp);
  }
  last_pressure_stamp_ = stamp;

  raw_.push_back({stamp, h});
  while (raw_.size() > 1 && raw_.front().t < stamp - b.median_window) raw_.pop_front();

  // Hampel filter: the window's centre sample passes unless it lies more than three robust
  // standard deviations from the window's median (a door slam), then the median replaces
  // it. Gaussian noise keeps its full averaging power; short spikes are removed.
  std::vector<double> values;
  values.reserve(raw_.size());
  for (const auto& r : raw_) values.push_back(r.value);
  const double median = medianOf(values);
  for (auto& v : values) v = std::abs(v - median);
  const double mad = medianOf(values);
  const TimedValue& centre = raw_[raw_.size() / 2];
  const bool outlier = std::abs(centre.value - median) > kHampelSigmas * 1.4826 * mad;
  filtered_.push_back({centre.t, outlier ? median : centre.value});
  processFiltered(stamp);
  for (std::size_t i = first_new_event; i < events_.size(); ++i) events_[i].decided_at = stamp;
  return true;
}

void FloorDetector::processFiltered(double now) {
  const double vw = options_.barometer.velocity_window;
  const double newest = filtered_.back().t;
  double st = 0.0, sh = 0.0;
  std::size_t n = 0;
  double first = kInf;
  for (auto it = filtered_.rbegin(); it != filtered_.rend() && it->t >= newest - vw; ++it) {
    st += it->t;
    sh += it->value;
    first = it->t;
    ++n;
  }
  if (n >= 3 && newest - first >= 0.5 * vw) {
    const double mt = st / static_cast<double>(n);
    const double mh = sh / static_cast<double>(n);
    double stt = 0.0, sth = 0.0;
    for (auto it = filtered_.rbegin(); it != filtered_.rend() && it->t >= newest - vw; ++it) {
      stt += (it->t - mt) * (it->t - mt);
      sth += (it->t - mt) * (it->value - mh);
    }
    if (stt > 0.0) {
      velocity_valid_ = true;
      last_velocity_ = sth / stt;
      window_height_ = mh;
      onVelocity(mt, last_velocity_, now);
    }
  } else {
    velocity_valid_ = false;
  }
  trimHistories(now);
}

void FloorDetector::trimHistories(double now) {
  double keep_from = now - historySeconds();
  if (state_ != State::kOnFloor) keep_from = std::min(keep_from, onset_ - historySeconds());
  // The filtered series is needed only for the reference before a ride and the quiet
  // window after it, both within historySeconds() of now or of the onset.
  const double filtered_from = now - historySeconds();
  while (filtered_.size() > 1 && filtered_.front().t < filtered_from) filtered_.pop_front();
  while (!imu_.empty() && (imu_.front().t < keep_from || imu_.size() > kMaxSamplesKept)) {
    imu_.pop_front();
  }
  while (!odom_.empty() && (odom_.front().t < keep_from || odom_.size() > kMaxSamplesKept)) {
    odom_.pop_front();
  }
  while (!scan_similarity_.empty() &&
         (scan_similarity_.front().t < keep_from || scan_similarity_.size() > kMaxSamplesKept)) {
    scan_similarity_.pop_front();
  }
}

FloorDetector::Window FloorDetector::filteredWindow(double from, double to) const {
  Window w;
  double s = 0.0, ss = 0.0, t0 = kInf, t1 = -kInf;
  for (const auto& f : filtered_) {
    if (f.t < from || f.t > to) continue;
    s += f.value;
    ss += f.value * f.value;
    t0 = std::min(t0, f.t);
    t1 = std::max(t1, f.t);
    ++w.count;
  }
  if (w.count == 0) return w;
  const double n = static_cast<double>(w.count);
  w.mean = s / n;
  w.stddev = std::sqrt(std::max(0.0, ss / n - w.mean * w.mean));
  w.span = t1 - t0;
  w.stddev /= std::sqrt(n);  // standard error of the mean (Hampel output is white)
  return w;
}

void FloorDetector::onVelocity(double t_v, double v, double /*now*/) {
  const auto& t = options_.transit;
  switch (state_) {
    case State::kOnFloor:
      if (std::abs(v) >= t.start_velocity) beginCandidate(t_v, v);
      break;
    case State::kCandidate:
      if (std::abs(v) >= t.end_velocity && sign(v) == candidate_sign_) {
        transit_velocity_.push_back({t_v, v});
        peak_speed_ = std::max(peak_speed_, std::abs(v));
        if (t_v - candidate_since_ >= t.min_duration &&
            std::abs(window_height_ - start_height_) >= t.min_start_change) {
          confirmTransit();
        }
      } else {
        // Too short to be a ride: a door slam that outlived the median, a bump.
        ++stats_.cancelled_candidates;
        common::logDebug(
            str("floor_detector: vertical motion at t=", candidate_since_, " too short, ignored"));
        state_ = State::kOnFloor;
        transit_velocity_.clear();
      }
      break;
    case State::kTransit:
      transit_velocity_.push_back({t_v, v});
      peak_speed_ = std::max(peak_speed_, std::abs(v));
      if (quiet_since_ < 0.0) {
        if (std::abs(v) < t.end_velocity) {
          quiet_since_ = t_v;
          quiet_height_ = window_height_;
          maybeEndTransit(t_v);
        }
      } else if (std::abs(v) >= t.start_velocity &&
                 std::abs(window_height_ - quiet_height_) >= t.min_start_change) {
        // Moving on (the next flight of stairs). Noise makes the velocity poke above the
        // thresholds now and then, but it does not move the height this far.
        quiet_since_ = -1.0;
      } else if (std::abs(v) < t.end_velocity) {
        maybeEndTransit(t_v);  // only while truly still: the end window must be level
      }
      break;
  }
}

void FloorDetector::beginCandidate(double t_v, double v) {
  const double vw = options_.barometer.velocity_window;
  const double mw = options_.barometer.median_window;
  // The slope window that crossed the threshold holds the start of the motion.
  onset_ = t_v - 0.5 * vw;
  const double ref_end = onset_ - 0.5 * mw;
  Window w = filteredWindow(ref_end - options_.transit.reference_window, ref_end);
  if (w.count == 0) w = filteredWindow(-kInf, ref_end);
  if (w.count == 0) {
    w.mean = filtered_.front().value;
    w.stddev = 0.0;
  }
  start_height_ = w.mean;
  start_height_stddev_ = w.stddev;
  state_ = State::kCandidate;
  silent_transit_ = false;
  candidate_since_ = t_v;
  candidate_sign_ = sign(v);
  quiet_since_ = -1.0;
  peak_speed_ = std::abs(v);
  transit_velocity_.assign(1, {t_v, v});
}

void FloorDetector::confirmTransit() {
  state_ = State::kTransit;
  quiet_since_ = -1.0;
  if (!silent_transit_ && pending_ && identity_wait_ > 0.0) {
    holdForIdentity();  // the TransitStarted names the floor left: wait for its identity
    return;
  }
  if (!silent_transit_) {
    FloorEvent e;
    e.type = FloorEventType::kTransitStarted;
    e.stamp = onset_;
    e.start_stamp = onset_;
    e.from_floor = floors_[current_floor_].id;
    e.from_height = floors_[current_floor_].height;
    e.floor_id = e.from_floor;
    e.floor_height = e.from_height;
    events_.push_back(e);
    common::logInfo(
        str("floor_detector: transit started at t=", onset_, " from floor ", e.from_floor));
  }
}

void FloorDetector::maybeEndTransit(double t_v) {
  const auto& t = options_.transit;
  const auto& f = options_.floors;
  const double quiet = t_v - quiet_since_;
  if (quiet < t.settle_time) return;
  const double mw = options_.barometer.median_window;
  const Window end = filteredWindow(quiet_since_ + 0.5 * mw, kInf);
  if (end.count < 3) return;
  const double dh = end.mean - start_height_;
  const double arrival = floors_[current_floor_].height + height_offset_ + dh;
  std::size_t nearest = 0;
  for (std::size_t i = 1; i < floors_.size(); ++i) {
    if (std::abs(floors_[i].height - arrival) < std::abs(floors_[nearest].height - arrival)) {
      nearest = i;
    }
  }
  const bool matched = std::abs(floors_[nearest].height - arrival) <= f.match_tolerance;
  const int current = current_floor_;
  if (matched && static_cast<int>(nearest) != current) {
    endTransit(static_cast<int>(nearest), true, false, arrival);
    return;
  }
  // A new floor, or no change (a ramp, a landing): wait longer, the robot may go on.
  if (quiet < t.new_floor_settle_time) return;
  // Measured from the floor, not from where this ride began (a half landing in between).
  const double from_floor = std::abs(arrival - floors_[current_floor_].height);
  if (!matched && from_floor >= f.min_change_fraction * f.storey_height) {
    floors_.push_back(Floor{static_cast<int>(floors_.size()), arrival, 0, false});
    endTransit(static_cast<int>(floors_.size()) - 1, true, true, arrival);
  } else {
    endTransit(current, false, false, arrival);
  }
}

void FloorDetector::endTransit(int floor_index, bool changed, bool created, double arrival) {
  const auto& b = options_.barometer;
  const auto& c = options_.corroboration;
  const double mw = b.median_window;
  const Window end = filteredWindow(quiet_since_ + 0.5 * mw, kInf);
  const double dh = end.mean - start_height_;
  const double motion_end = quiet_since_;
  const double duration = std::max(motion_end - onset_, 1e-3);

  // Uncertainty: both plateaus and the sensor's own over the ride: for the barometer the
  // weather drift and the temperature's scale, for the IMU what its integration gathered.
  double sensor_variance = 0.0;
  if (options_.sensors.barometer) {
    const double height_per_pascal = scaleHeight(b.temperature_kelvin) / last_pressure_;
    const double drift = b.max_drift_rate / 3600.0 * height_per_pascal * duration;
    const double scale = std::abs(dh) * b.temperature_uncertainty_kelvin / b.temperature_kelvin;
    sensor_variance = drift * drift + scale * scale;
  } else {
    sensor_variance = imu_height_.variance(onset_ - mw, motion_end + mw);
  }
  // After a ride that stayed on the floor (a half landing) this ride continues from the
  // offset it left: the change reported is from the floor the robot left.
  const double stddev =
      std::sqrt(start_height_stddev_ * start_height_stddev_ + end.stddev * end.stddev +
                sensor_variance + offset_stddev_ * offset_stddev_);
  const double change = height_offset_ + dh;

  Evidence e;
  // Barometer: sustained vertical motion was seen; a known floor's height adds to it.
  e.log_odds = 1.0;
  if (changed && !created) {
    const double residual = std::abs(floors_[floor_index].height - arrival);
    e.log_odds += 1.0 * (1.0 - residual / options_.floors.match_tolerance);
  }
  if (silent_transit_) e.log_odds -= 1.5;  // the ride fell in a gap of the barometer
  // Odometry and scans are judged over the core of the motion (vertical speed above half
  // its peak), not the padded interval that also holds the boarding. The typical speed
  // there (a median: a noisy peak says little) tells a cabin from stairs.
  double core_start = onset_, core_end = motion_end;
  bool core_found = false;
  std::vector<double> core_speeds;
  for (const auto& p : transit_velocity_) {
    if (std::abs(p.value) < 0.5 * peak_speed_) continue;
    if (!core_found) core_start = p.t;
    core_end = p.t;
    core_found = true;
    core_speeds.push_back(std::abs(p.value));
  }
  const double typical_speed = core_speeds.empty() ? 0.0 : medianOf(core_speeds);
  if (typical_speed >= c.elevator_min_speed) e.elevator_votes += 1.0;
  if (typical_speed <= c.stairs_max_speed) e.stairs_votes += 1.0;
  if (options_.sensors.imu) imuEvidence(onset_, motion_end, e);
  if (options_.sensors.odometry) odometryEvidence(core_start, core_end, e);
  if (options_.sensors.scan) scanEvidence(core_start, core_end, e);

  Floor& reached = floors_[floor_index];
  const double reached_height_before = reached.height;
  if (changed && !created && !reached.configured) {
    // Running mean of the arrivals at a floor observed (not configured) so far.
    reached.height += (arrival - reached.height) / static_cast<double>(reached.arrivals + 1);
  }
  if (changed) ++reached.arrivals;

  // An earlier unsure arrival still unanswered (its answer could only come after this
  // ride, e.g. from a gap): the height's choice stands.
  if (pending_) {
    ++stats_.identities_not_answered;
    pending_.reset();
  }
  FloorEvent ev;
  if (changed || silent_transit_)
    identityCandidates(arrival, stddev, floor_index, created, changed, reached_height_before, ev);
  if (changed || !silent_transit_ || ev.identityUnsure()) {
    if (silent_transit_) {
      FloorEvent s;
      s.type = FloorEventType::kTransitStarted;
      s.stamp = s.start_stamp = onset_;
      s.from_floor = floors_[current_floor_].id;
      s.from_height = floors_[current_floor_].height;
      s.floor_id = s.from_floor;
      s.floor_height = s.from_height;
      events_.push_back(s);
    }
    ev.type = FloorEventType::kTransitEnded;
    ev.stamp = motion_end;
    ev.start_stamp = onset_;
    ev.from_floor = floors_[current_floor_].id;
    ev.from_height = floors_[current_floor_].height;
    ev.height_change = change;
    ev.height_change_stddev = stddev;
    ev.floor_id = reached.id;
    ev.floor_height = reached.height;
    ev.floor_changed = changed;
    ev.new_floor = created;
    ev.confidence = sigmoid(e.log_odds);
    ev.mode =
        e.elevator_votes > e.stairs_votes
            ? TransitMode::kElevator
            : (e.stairs_votes > e.elevator_votes ? TransitMode::kStairs : TransitMode::kUnknown);
    events_.push_back(ev);
    common::logInfo(str("floor_detector: transit ended at t=", motion_end, ": floor ",
                        ev.from_floor, " -> ", ev.floor_id, created ? " (new)" : "",
                        ev.identityUnsure() ? " (unsure: the mapper decides)" : "", ", dz=", change,
                        " +- ", stddev, ", ", transitModeName(ev.mode), ", confidence ",
                        ev.confidence));
  }
  current_floor_ = floor_index;
  height_offset_ = changed ? 0.0 : arrival - floors_[floor_index].height;
  offset_stddev_ = changed ? 0.0 : stddev;
  state_ = State::kOnFloor;
  silent_transit_ = false;
  quiet_since_ = -1.0;
  transit_velocity_.clear();
}

void FloorDetector::handleGap(double gap_start, double gap_end) {
  ++stats_.gaps;
  common::logWarn(str("floor_detector: no ", options_.sensors.barometer ? "pressure" : "IMU height",
                      " between t=", gap_start, " and t=", gap_end, " (", gap_end - gap_start,
                      " s); filter restarted"));
  raw_.clear();
  velocity_valid_ = false;
  if (state_ == State::kOnFloor) {
    // Compare what comes after the gap with the floor's height before it; report only if
    // the floor changed.
    const double ref_end = filtered_.empty() ? gap_start : filtered_.back().t;
    Window w = filteredWindow(ref_end - options_.transit.reference_window, ref_end);
    if (w.count == 0) return;  // nothing before the gap to compare with
    start_height_ = w.mean;
    start_height_stddev_ = w.stddev;
    onset_ = gap_start;
    silent_transit_ = true;
    peak_speed_ = 0.0;
    transit_velocity_.clear();
  } else if (state_ == State::kCandidate) {
    silent_transit_ = true;
  }
  state_ = State::kTransit;
  quiet_since_ = -1.0;
  filtered_.clear();
}

}  // namespace storey::detection
