// FloorDetector's corroborating evidence for a pressure transit: the IMU's vertical
// motion, the odometry standing still, the laser's view changing.
#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "storey/common/log.h"
#include "storey/detection/floor_detector.h"

namespace storey::detection {

using common::str;

namespace {

// Pearson correlation of paired values; NaN when either side has no variance.
double correlation(const std::vector<double>& a, const std::vector<double>& b) {
  const double n = static_cast<double>(a.size());
  double ma = 0.0, mb = 0.0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    ma += a[i];
    mb += b[i];
  }
  ma /= n;
  mb /= n;
  double sab = 0.0, saa = 0.0, sbb = 0.0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    sab += (a[i] - ma) * (b[i] - mb);
    saa += (a[i] - ma) * (a[i] - ma);
    sbb += (b[i] - mb) * (b[i] - mb);
  }
  if (saa <= 1e-12 || sbb <= 1e-12) return std::numeric_limits<double>::quiet_NaN();
  return sab / std::sqrt(saa * sbb);
}

}  // namespace

void FloorDetector::imuEvidence(double start, double end, Evidence& e) const {
  if (imu_.size() < 10) return;
  const double ref = options_.transit.reference_window;
  double bias = 0.0;
  std::size_t nb = 0;
  for (const auto& s : imu_) {
    if (s.t >= start - ref && s.t <= start) {
      bias += s.value;
      ++nb;
    }
  }
  if (nb < 5) return;
  bias /= static_cast<double>(nb);
  // Vertical velocity from the accelerometer over the ride, detrended so it ends at rest.
  std::vector<TimedValue> vel;
  double v = 0.0, sa = 0.0, saa = 0.0;
  const TimedValue* prev = nullptr;
  for (const auto& s : imu_) {
    if (s.t < start || s.t > end) continue;
    if (prev) v += 0.5 * ((prev->value - bias) + (s.value - bias)) * (s.t - prev->t);
    vel.push_back({s.t, v});
    sa += s.value - bias;
    saa += (s.value - bias) * (s.value - bias);
    prev = &s;
  }
  if (vel.size() < 10 || vel.front().t > start + 1.0 || vel.back().t < end - 1.0) return;
  const double t0 = vel.front().t, t1 = vel.back().t;
  const double v1 = vel.back().value;
  double peak = 0.0;
  for (auto& p : vel) {
    p.value -= v1 * (p.t - t0) / std::max(t1 - t0, 1e-6);
    peak = std::max(peak, std::abs(p.value));
  }
  std::vector<double> baro, inertial;
  std::size_t j = 0;
  for (const auto& p : transit_velocity_) {
    if (p.t < t0 || p.t > t1) continue;
    while (j + 1 < vel.size() && vel[j + 1].t < p.t) ++j;
    baro.push_back(p.value);
    inertial.push_back(vel[j].value);
  }
  if (baro.size() < 5) return;
  const double rho = correlation(baro, inertial);
  const double n = static_cast<double>(vel.size());
  const double accel_std = std::sqrt(std::max(0.0, saa / n - (sa / n) * (sa / n)));
  if (std::isfinite(rho)) {
    if (rho > 0.5) e.log_odds += 1.0;
    if (rho < 0.0) e.log_odds -= 1.0;
    // A smooth accelerate-cruise-brake profile is a cabin; footfalls shake the robot.
    if (rho > 0.7 && peak >= 0.3 && accel_std < 0.7) e.elevator_votes += 1.0;
  }
  if (accel_std > 1.0) e.stairs_votes += 1.0;
}

void FloorDetector::odometryEvidence(double start, double end, Evidence& e) const {
  double path = 0.0;
  const OdomPoint* prev = nullptr;
  double first = std::numeric_limits<double>::infinity(),
         last = -std::numeric_limits<double>::infinity();
  for (const auto& p : odom_) {
    if (p.t < start || p.t > end) continue;
    if (prev) path += std::hypot(p.x - prev->x, p.y - prev->y);
    first = std::min(first, p.t);
    last = std::max(last, p.t);
    prev = &p;
  }
  if (!prev || first > start + 1.0 || last < end - 1.0 || last <= first) return;
  const double speed = path / (last - first);
  const auto& c = options_.corroboration;
  if (speed <= c.stationary_speed) {
    e.elevator_votes += 2.0;
    e.log_odds += 0.5;
  } else if (speed <= c.max_planar_speed) {
    e.stairs_votes += 2.0;
    e.log_odds += 0.5;
  } else {
    e.log_odds -= 1.0;  // driving fast on a level floor does not take it up a storey
  }
}

void FloorDetector::scanEvidence(double start, double end, Evidence& e) const {
  double sum = 0.0;
  std::size_t n = 0;
  for (const auto& s : scan_similarity_) {
    if (s.t < start || s.t > end) continue;
    sum += s.value;
    ++n;
  }
  if (n < 3) return;
  const double mean = sum / static_cast<double>(n);
  const auto& c = options_.corroboration;
  if (mean >= c.static_scan_similarity) {
    e.elevator_votes += 2.0;
    e.log_odds += 1.0;
  } else if (mean <= c.moving_scan_similarity) {
    e.stairs_votes += 1.0;
  }
}

// The corroborating streams (and, without a barometer, the IMU heights' sources).
bool FloorDetector::addImu(const sensor::ImuSample& sample) {
  if (!options_.sensors.imu) return true;
  if (holding_) return queueIfHolding(QueuedInput::of(sample));
  const bool heights = !options_.sensors.barometer;
  if (!std::isfinite(sample.stamp) || !sample.linear_acceleration.allFinite()) {
    rejectLog("IMU sample with non-finite values", stats_.rejected_other);
    return false;
  }
  if (sample.stamp <= last_imu_stamp_) {
    rejectLog(str("IMU sample at t=", sample.stamp, " out of order"), stats_.rejected_other);
    return false;
  }
  last_imu_stamp_ = sample.stamp;
  if (heights) {
    imu_height_.addImu(sample.stamp, sample.linear_acceleration);
    takeImuHeights();
  }
  imu_.push_back({sample.stamp, sample.linear_acceleration.norm()});
  if (state_ == State::kOnFloor) {
    while (imu_.front().t < sample.stamp - historySeconds()) imu_.pop_front();
  } else if (imu_.size() > kMaxSamplesKept) {
    imu_.pop_front();
  }
  return true;
}

bool FloorDetector::addOdometry(const sensor::OdometrySample& sample) {
  if (!options_.sensors.odometry) return true;
  if (holding_) return queueIfHolding(QueuedInput::of(sample));
  const bool heights = !options_.sensors.barometer;
  const auto& t = sample.pose.translation();
  if (!std::isfinite(sample.stamp) || !std::isfinite(t.x()) || !std::isfinite(t.y())) {
    rejectLog("odometry sample with non-finite values", stats_.rejected_other);
    return false;
  }
  if (sample.stamp <= last_odom_stamp_) {
    rejectLog(str("odometry sample at t=", sample.stamp, " out of order"), stats_.rejected_other);
    return false;
  }
  last_odom_stamp_ = sample.stamp;
  if (heights) {
    imu_height_.addOdometry(sample.stamp, t.x(), t.y(), sample.pose.theta());
    takeImuHeights();
  }
  odom_.push_back({sample.stamp, t.x(), t.y()});
  if (state_ == State::kOnFloor) {
    while (odom_.front().t < sample.stamp - historySeconds()) odom_.pop_front();
  } else if (odom_.size() > kMaxSamplesKept) {
    odom_.pop_front();
  }
  return true;
}

bool FloorDetector::addScan(const sensor::LaserScan& scan) {
  if (!options_.sensors.scan) return true;
  if (holding_) return queueIfHolding(QueuedInput::of(scan));
  const std::string problem = scan.validate();
  if (!std::isfinite(scan.stamp) || !problem.empty()) {
    rejectLog(str("scan at t=", scan.stamp, ": ", problem.empty() ? "bad stamp" : problem),
              stats_.rejected_other);
    return false;
  }
  if (scan.stamp <= last_scan_stamp_) {
    rejectLog(str("scan at t=", scan.stamp, " out of order"), stats_.rejected_other);
    return false;
  }
  last_scan_stamp_ = scan.stamp;
  // Compare with the newest scan at least a second older: in a cabin nothing changes, on
  // stairs the robot has moved a quarter metre or turned.
  const sensor::LaserScan* previous = nullptr;
  for (auto it = scans_.rbegin(); it != scans_.rend(); ++it) {
    if (it->stamp <= scan.stamp - kScanLag) {
      previous = &*it;
      break;
    }
  }
  if (previous && scan.stamp - previous->stamp < 3.0 * kScanLag) {
    const double sim = scanSimilarity(*previous, scan, options_.corroboration.scan);
    if (sim >= 0.0) scan_similarity_.push_back({scan.stamp, sim});
  }
  scans_.push_back(scan);
  while (scans_.size() > 1 &&
         (scans_.front().stamp < scan.stamp - 3.0 * kScanLag || scans_.size() > kMaxScansKept)) {
    scans_.pop_front();
  }
  return true;
}

}  // namespace storey::detection
