// Height for a robot without a barometer, from its accelerometer and wheel odometry:
// - standing (a cabin): the vertical specific force, less the level measured at rest
//   just before, integrated twice from the first acceleration pulse until the robot has
//   braked and is quiet again; the velocity must then be zero, and what is left of it
//   (a constant bias error) is taken out of the height (a zero-velocity update);
// - driving (stairs, a ramp): the ground's pitch, from the forward specific force less
//   the forward acceleration the odometry gives, times the distance the wheels turned.
// Between these the height holds still. The output is a height series the floor
// detector treats like the barometer's (relative: only its changes matter).
//
// Feed IMU and odometry samples each in time order; IMU samples wait for the odometry
// that covers them (at most kOdometryWait seconds).
#pragma once

#include <Eigen/Core>
#include <deque>
#include <vector>

#include "storey/common/shipped_config.h"

namespace storey::detection {

// The shipped file's detector values (config/floor_detector.yaml), the defaults below.
namespace shipped_detector = shipped::floor_detector::detector;

// The accelerometer's datasheet figures.
struct ImuHeightOptions {
  // m/s^2/sqrt(Hz), white noise
  double accel_noise_density = shipped_detector::imu::accel_noise_density;
  // m/s^2/sqrt(s), the bias's random walk
  double accel_bias_walk = shipped_detector::imu::accel_bias_walk;
  // The wheels' distance error per metre driven (slip): a flight's height is off by the
  // same fraction.
  double odometry_translation_per_meter = shipped_detector::odometry::translation_per_meter;
  // The detector's corroboration values: slower than stationary_speed is standing; no
  // cabin cruises slower than cabin_min_speed.
  // m/s
  double stationary_speed = shipped_detector::corroboration::stationary_speed;
  // m/s
  double cabin_min_speed = shipped_detector::corroboration::elevator_min_speed;
};

struct HeightSample {
  double t = 0.0;
  double height = 0.0;  // m, relative
};

class ImuHeight {
 public:
  explicit ImuHeight(const ImuHeightOptions& options);

  void addImu(double t, const Eigen::Vector3d& specific_force);
  void addOdometry(double t, double x, double y, double theta);
  // Heights decided since the last call, at most ten a second, oldest first.
  std::vector<HeightSample> take();
  // Variance the height gained from rides and slopes that overlap [t0, t1], m^2; infinite
  // when the IMU samples have a gap there longer than half a second.
  double variance(double t0, double t1) const;
  // Continue from this height (a restarted detector's reference).
  void setHeight(double height) { height_ = height; }

 private:
  // Threshold on the 0.5 s mean of the vertical force that starts a ride, m/s^2.
  double pulseThreshold() const;

  struct Imu {
    double t;
    double up;       // |specific force|: gravity and the vertical acceleration
    double forward;  // specific force along the robot's x axis
  };
  struct Odom {
    double t, x, y, theta;
  };
  struct Segment {
    double t0, t1, variance;
    double slope_height = 0.0;  // height gained on a slope (its odometry error scales it)
  };

  void process(const Imu& s);
  bool odometryAt(double t, Odom* out) const;
  double speedAt(double t) const;  // m/s along the heading, signed; 0 without odometry
  void standing(const Imu& s);
  void driving(const Imu& s);
  void closeBlock(double t);
  void startRide();
  void integrate(const Imu& s);
  void endRide(double t_end);
  void dropRide();  // not a ride after all: the height goes back
  void emit(double t);

  ImuHeightOptions options_;
  std::deque<Imu> pending_;  // waiting for odometry
  std::deque<Odom> odom_;
  bool have_odometry_ = false;
  double last_imu_ = -1e300;
  bool started_ = false;  // a sample was processed (last_t_ is its stamp)

  double height_ = 0.0;
  std::vector<HeightSample> out_;
  double next_emit_ = -1e300;
  std::vector<Segment> segments_;

  // Standing: the level at rest and the last half second.
  std::deque<Imu> rest_;
  std::deque<Imu> window_;
  double window_sum_ = 0.0;
  // A ride in progress.
  bool ride_ = false;
  double ride_onset_ = 0.0, ride_level_ = 0.0, ride_v_ = 0.0, ride_h_ = 0.0;
  double pulse_v_ = 0.0, pulse_peak_ = 0.0;  // velocity from the pulses alone
  double last_pulse_ = 0.0, pulse_since_ = 0.0, last_t_ = 0.0, last_a_ = 0.0;
  double still_since_ = 1e300;  // standing since (1e300: driving)
  std::vector<Imu> ride_samples_;
  double height_at_onset_ = 0.0;

  // Driving: one-second blocks.
  double block_start_ = -1e300, block_forward_ = 0.0;
  std::size_t block_count_ = 0;
  bool level_valid_ = false;
  double level_forward_ = 0.0;  // forward force on level ground (mounting tilt and bias)
};

}  // namespace storey::detection
