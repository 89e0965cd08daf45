#include "storey/detection/imu_height.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace storey::detection {
namespace {

constexpr double kGravity = 9.80665;
constexpr double kWindow = 0.5;      // s: mean that tells a pulse from noise
constexpr double kRestWindow = 4.0;  // s of rest before a ride give its level
constexpr double kMinRest = 1.0;     // s of rest needed before a ride can start
constexpr double kSettle = 2.0;      // s quiet after the last pulse before a ride ends
constexpr double kMaxRide = 300.0;   // s; a longer "ride" is a drifting bias: ended
// A cabin reaches its speed within seconds; a "pulse" that lasts longer is a shift of
// the level (a tilt, a bias step), and the ride it started is dropped.
constexpr double kMaxPulse = 10.0;     // s
constexpr double kBlock = 1.0;         // s: pitch is measured over blocks this long
constexpr double kOdometryWait = 1.0;  // s an IMU sample waits for its odometry
constexpr double kEmitPeriod = 0.1;    // s between heights handed on
constexpr double kSpeedSpan = 0.5;     // s: speed from the odometry over this span, centred
constexpr double kLevelTime = 30.0;    // s: time constant of the level forward force
// Below this pitch the ground counts as level for the forward force's reference; steeper
// than a ramp's tolerance of bumps, shallower than any ramp built to be one (1:12).
const double kLevelSine = std::sin(2.0 * 3.14159265358979323846 / 180.0);

}  // namespace

ImuHeight::ImuHeight(const ImuHeightOptions& options) : options_(options) {}

double ImuHeight::pulseThreshold() const {
  // Six standard deviations of the window's mean: noise alone does not start a ride.
  return 6.0 * options_.accel_noise_density / std::sqrt(kWindow);
}

void ImuHeight::addImu(double t, const Eigen::Vector3d& f) {
  if (!(t > last_imu_)) return;
  last_imu_ = t;
  pending_.push_back({t, f.norm(), f.x()});
  while (!pending_.empty()) {
    const bool covered = have_odometry_ && pending_.front().t + 0.5 * kSpeedSpan <= odom_.back().t;
    if (!covered && last_imu_ - pending_.front().t <= kOdometryWait) break;
    process(pending_.front());
    pending_.pop_front();
  }
}

void ImuHeight::addOdometry(double t, double x, double y, double theta) {
  if (have_odometry_ && !(t > odom_.back().t)) return;
  have_odometry_ = true;
  odom_.push_back({t, x, y, theta});
  while (!pending_.empty() && pending_.front().t + 0.5 * kSpeedSpan <= t) {
    process(pending_.front());
    pending_.pop_front();
  }
  // Keep what the oldest waiting sample and the current block still need.
  double oldest = pending_.empty() ? last_t_ : std::min(last_t_, pending_.front().t);
  if (block_start_ > -1e299) oldest = std::min(oldest, block_start_);
  const double keep = oldest - 2.0 * kSpeedSpan - kBlock;
  while (odom_.size() > 2 && odom_[1].t < keep) odom_.pop_front();
}

std::vector<HeightSample> ImuHeight::take() {
  std::vector<HeightSample> out;
  out.swap(out_);
  return out;
}

double ImuHeight::variance(double t0, double t1) const {
  double v = 0.0;
  const double k = options_.odometry_translation_per_meter;
  for (const auto& s : segments_) {
    if (s.t1 >= t0 && s.t0 <= t1) v += s.variance + k * k * s.slope_height * s.slope_height;
  }
  return v;
}

bool ImuHeight::odometryAt(double t, Odom* out) const {
  if (odom_.empty() || t < odom_.front().t || t > odom_.back().t) return false;
  auto it = std::lower_bound(odom_.begin(), odom_.end(), t,
                             [](const Odom& o, double time) { return o.t < time; });
  if (it == odom_.begin()) {
    *out = *it;
    return true;
  }
  const Odom& b = *it;
  const Odom& a = *std::prev(it);
  const double w = b.t > a.t ? (t - a.t) / (b.t - a.t) : 1.0;
  out->t = t;
  out->x = a.x + w * (b.x - a.x);
  out->y = a.y + w * (b.y - a.y);
  out->theta = a.theta + w * std::remainder(b.theta - a.theta, 2.0 * 3.14159265358979323846);
  return true;
}

double ImuHeight::speedAt(double t) const {
  Odom a, b;
  // Centred, so that a speed change is not seen late (the samples wait for it).
  if (!odometryAt(t - 0.5 * kSpeedSpan, &a) || !odometryAt(t + 0.5 * kSpeedSpan, &b)) return 0.0;
  const double heading = b.theta;
  return ((b.x - a.x) * std::cos(heading) + (b.y - a.y) * std::sin(heading)) / kSpeedSpan;
}

void ImuHeight::process(const Imu& s) {
  // A gap longer than the window that finds a pulse may hide part of a ride, or all of
  // it: the height across it is unknown (the floor detector then asks which floor).
  if (started_ && s.t - last_t_ > kWindow) {
    segments_.push_back({last_t_, s.t, std::numeric_limits<double>::infinity(), 0.0});
    ride_ = false;
    window_.clear();
    window_sum_ = 0.0;
    rest_.clear();
    block_start_ = -1e300;
    still_since_ = 1e300;
  }
  started_ = true;
  const bool still = std::abs(speedAt(s.t)) < options_.stationary_speed;
  if (!still) {
    still_since_ = 1e300;
  } else if (still_since_ > s.t) {
    still_since_ = s.t;
  }
  if (ride_ && !still) endRide(last_t_);  // drove out of the cabin: it had stopped
  if (ride_) {
    integrate(s);
  } else if (still) {
    standing(s);
  } else {
    driving(s);
  }
  last_t_ = s.t;
  emit(s.t);
}

void ImuHeight::standing(const Imu& s) {
  if (block_start_ > -1e299) closeBlock(last_t_);  // the drive's last, partial block
  block_start_ = -1e300;
  // The first moments of a stop still hold the drive (the speed is a centred mean).
  if (s.t < still_since_ + kSpeedSpan) return;
  // Standing, the forward force is the level's: the mounting's tilt and the bias.
  if (!level_valid_) {
    level_forward_ = s.forward;
    level_valid_ = true;
  } else if (std::abs(s.forward - level_forward_) < kLevelSine * kGravity) {
    level_forward_ += (s.forward - level_forward_) * std::min(1.0, (s.t - last_t_) / kLevelTime);
  }
  window_.push_back(s);
  window_sum_ += s.up;
  while (window_.front().t < s.t - kWindow) {
    window_sum_ -= window_.front().up;
    window_.pop_front();
  }
  const double onset = window_.front().t;
  double level = 0.0;
  std::size_t n = 0;
  for (const auto& r : rest_) {
    if (r.t >= onset) break;
    level += r.up;
    ++n;
  }
  const bool rested = n > 0 && rest_.front().t <= onset - kMinRest;
  const double mean = window_sum_ / static_cast<double>(window_.size());
  if (rested && s.t - onset >= 0.9 * kWindow &&
      std::abs(mean - level / static_cast<double>(n)) > pulseThreshold()) {
    ride_level_ = level / static_cast<double>(n);
    ride_onset_ = onset;
    startRide();
    return;
  }
  rest_.push_back(s);
  while (rest_.front().t < s.t - kRestWindow) rest_.pop_front();
}

void ImuHeight::startRide() {
  ride_ = true;
  ride_v_ = ride_h_ = pulse_v_ = pulse_peak_ = 0.0;
  height_at_onset_ = height_;
  last_pulse_ = pulse_since_ = ride_onset_;
  // Integrate the window that showed the pulse, then every sample until the cabin stops.
  std::deque<Imu> samples;
  samples.swap(window_);
  window_sum_ = 0.0;
  rest_.clear();
  last_t_ = samples.front().t;
  last_a_ = samples.front().up - ride_level_;
  for (const auto& s : samples) integrate(s);
}

void ImuHeight::integrate(const Imu& s) {
  const double a = s.up - ride_level_;
  const double dt = s.t - last_t_;
  ride_v_ += 0.5 * (a + last_a_) * dt;
  ride_h_ += ride_v_ * dt;
  last_a_ = a;
  last_t_ = s.t;
  window_.push_back(s);
  window_sum_ += s.up;
  while (window_.front().t < s.t - kWindow) {
    window_sum_ -= window_.front().up;
    window_.pop_front();
  }
  const double mean = window_sum_ / static_cast<double>(window_.size()) - ride_level_;
  if (std::abs(mean) > pulseThreshold()) {
    if (last_pulse_ < s.t - 2.0 * dt) pulse_since_ = s.t;
    pulse_v_ += a * dt;
    pulse_peak_ = std::max(pulse_peak_, std::abs(pulse_v_));
    last_pulse_ = s.t;
    if (s.t - pulse_since_ > kMaxPulse) {
      dropRide();
      return;
    }
  }
  height_ = height_at_onset_ + ride_h_;
  // The cabin has stopped when it has been quiet a while and either the pulses cancel
  // (it braked as it started) or the velocity is below any cabin's (a jolt, not a ride).
  const bool quiet = s.t - last_pulse_ >= kSettle;
  const bool braked = std::abs(pulse_v_) < 0.5 * pulse_peak_;
  const bool slow = std::abs(ride_v_) < 0.5 * options_.cabin_min_speed;
  if ((quiet && (braked || slow)) || s.t - ride_onset_ > kMaxRide) endRide(s.t);
}

void ImuHeight::dropRide() {
  height_ = height_at_onset_;
  ride_ = false;
  window_.clear();
  window_sum_ = 0.0;
  rest_.clear();
}

void ImuHeight::endRide(double t_end) {
  // At rest again, the velocity v left over is the bias error's integral. With white noise
  // (density N) and a bias that walks (K) from the level measured before the ride, the
  // least-variance linear correction of the height is h - k v T, and its variance is
  // N^2 T^3 (1/3 - k + k^2) + K^2 T^5 (1/20 - k/4 + k^2/3).
  const double duration = std::max(t_end - ride_onset_, 1e-3);
  const double n2 = options_.accel_noise_density * options_.accel_noise_density;
  const double q = options_.accel_bias_walk * options_.accel_bias_walk;
  const double t3 = duration * duration * duration, t5 = t3 * duration * duration;
  const double k = (n2 * t3 + q * t5 / 4.0) / (2.0 * n2 * t3 + 2.0 * q * t5 / 3.0);
  height_ = height_at_onset_ + ride_h_ - k * ride_v_ * duration;
  const double variance =
      n2 * t3 * (1.0 / 3.0 - k + k * k) + q * t5 * (1.0 / 20.0 - k / 4.0 + k * k / 3.0);
  segments_.push_back({ride_onset_, last_pulse_, variance, 0.0});
  if (segments_.size() > 1000) segments_.erase(segments_.begin());
  ride_ = false;
  window_.clear();
  window_sum_ = 0.0;
  rest_.clear();
}

void ImuHeight::driving(const Imu& s) {
  window_.clear();
  window_sum_ = 0.0;
  rest_.clear();
  if (block_start_ < -1e299) {
    block_start_ = s.t;
    block_forward_ = 0.0;
    block_count_ = 0;
  }
  block_forward_ += s.forward;
  ++block_count_;
  if (s.t - block_start_ >= kBlock) closeBlock(s.t);
}

void ImuHeight::closeBlock(double t) {
  const double span = t - block_start_;
  Odom a, b;
  // The level is learnt standing: a drive before the first stop has nothing to compare.
  if (level_valid_ && block_count_ > 0 && span > 0.0 && odometryAt(block_start_, &a) &&
      odometryAt(t, &b)) {
    const double heading =
        std::atan2(std::sin(a.theta) + std::sin(b.theta), std::cos(a.theta) + std::cos(b.theta));
    const double along = (b.x - a.x) * std::cos(heading) + (b.y - a.y) * std::sin(heading);
    const double acceleration = (speedAt(t) - speedAt(block_start_)) / span;
    const double forward = block_forward_ / static_cast<double>(block_count_) - acceleration;
    const double sine = std::clamp((forward - level_forward_) / kGravity, -1.0, 1.0);
    if (std::abs(sine) < kLevelSine) {
      level_forward_ += (forward - level_forward_) * std::min(1.0, span / kLevelTime);
    } else {
      // On a slope: the level's uncertainty (the bias) and the block's noise, per metre.
      const double bias = options_.accel_bias_walk * std::sqrt(kLevelTime) / kGravity;
      const double noise = options_.accel_noise_density / std::sqrt(span) / kGravity;
      const double variance = (bias * bias + noise * noise) * along * along;
      if (segments_.empty() || segments_.back().t1 < block_start_ - 1e-9 ||
          std::isinf(segments_.back().variance))
        segments_.push_back({block_start_, block_start_, 0.0});
      Segment& segment = segments_.back();
      segment.t1 = t;
      segment.variance += variance;
      segment.slope_height += sine * along;
      height_ += sine * along;
    }
  }
  block_start_ = t;
  block_forward_ = 0.0;
  block_count_ = 0;
}

void ImuHeight::emit(double t) {
  if (t < next_emit_) return;
  out_.push_back({t, height_});
  next_emit_ = t + kEmitPeriod;
}

}  // namespace storey::detection
