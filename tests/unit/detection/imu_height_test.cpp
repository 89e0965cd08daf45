// ImuHeight on synthetic accelerometer and odometry streams: cabin rides between rests,
// jolts and tilts that are not rides, stairs from pitch and distance, level driving.
#include "storey/detection/imu_height.h"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <random>

namespace storey::detection {
namespace {

constexpr double kG = 9.80665;
constexpr double kPi = 3.14159265358979323846;

// The robot's true motion at time t: distance along its (fixed) heading, forward speed and
// acceleration along the ground, the ground's pitch, and the vertical acceleration of a cabin.
struct Motion {
  double s = 0.0, v = 0.0, a = 0.0, pitch = 0.0, cabin_a = 0.0;
};

struct Streams {
  double accel_sigma = 0.02;  // per sample at 50 Hz: 0.003 m/s^2/sqrt(Hz)
  Eigen::Vector3d bias = Eigen::Vector3d(0.01, -0.01, 0.03);
  std::function<double(double)> extra_up = [](double) { return 0.0; };
  double gap_from = 0.0, gap_to = 0.0;  // s: no IMU samples in between
};

// Feeds [0, end] s at 50 Hz (IMU) and 20 Hz (odometry) and returns the height at the end.
double run(ImuHeight& h, double end, const std::function<Motion(double)>& motion,
           const Streams& streams = {}) {
  std::mt19937 rng(7);
  std::normal_distribution<double> noise(0.0, streams.accel_sigma);
  double height = 0.0;
  const int imu_n = static_cast<int>(end * 50.0);
  int odom_k = 0;
  for (int k = 0; k <= imu_n; ++k) {
    const double t = k / 50.0;
    while (odom_k / 20.0 <= t) {
      const Motion m = motion(odom_k / 20.0);
      h.addOdometry(odom_k / 20.0, m.s, 0.0, 0.0);
      ++odom_k;
    }
    const Motion m = motion(t);
    const double c = std::cos(m.pitch), sn = std::sin(m.pitch);
    Eigen::Vector3d f(m.a + kG * sn, 0.0, kG * c + m.cabin_a + streams.extra_up(t));
    f += streams.bias + Eigen::Vector3d(noise(rng), noise(rng), noise(rng));
    if (t > streams.gap_from && t < streams.gap_to) continue;
    h.addImu(t, f);
    for (const auto& sample : h.take()) height = sample.height;
  }
  return height;
}

// A trapezoidal cabin ride of `rise` metres starting at t0 (0.5 m/s^2, 1 m/s).
double cabinAcceleration(double t, double t0, double rise) {
  const double a = 0.5, v = 1.0, ta = v / a;
  const double cruise = std::abs(rise) / v - ta;
  const double sign = rise > 0 ? 1.0 : -1.0;
  const double u = t - t0;
  if (u < 0.0) return 0.0;
  if (u < ta) return sign * a;
  if (u < ta + cruise) return 0.0;
  if (u < 2.0 * ta + cruise) return -sign * a;
  return 0.0;
}

TEST(ImuHeight, ACabinRideIsIntegratedBetweenRests) {
  for (double rise : {3.0, -7.5, 12.0}) {
    ImuHeight h{ImuHeightOptions{}};
    const double height = run(h, 60.0, [&](double t) {
      Motion m;
      m.cabin_a = cabinAcceleration(t, 10.0, rise);
      return m;
    });
    const double sigma = std::sqrt(h.variance(0.0, 60.0));
    EXPECT_GT(sigma, 0.0);
    EXPECT_LT(sigma, 0.3) << rise;  // the height-change goal (RMSE 0.3 m)
    // Within the goal (0.3 m RMSE) and within the uncertainty the tracker states.
    EXPECT_NEAR(height, rise, std::max(4.0 * sigma, 0.02)) << rise;
  }
}

TEST(ImuHeight, ABiasThatWalksDuringTheRideIsCorrectedAtRest) {
  // The vertical bias drifts by 0.01 m/s^2 over a 15 s ride: uncorrected, 1 m of height.
  Streams streams;
  streams.extra_up = [](double t) {
    return t > 10.0 ? std::min(t - 10.0, 15.0) * 0.01 / 15.0 : 0.0;
  };
  ImuHeight h{ImuHeightOptions{}};
  const double height = run(
      h, 60.0,
      [](double t) {
        Motion m;
        m.cabin_a = cabinAcceleration(t, 10.0, 12.0);
        return m;
      },
      streams);
  EXPECT_NEAR(height, 12.0, 0.3);
}

TEST(ImuHeight, AJoltWhileStandingIsNotARide) {
  Streams streams;
  // A door slam: the floor shakes at 10 Hz, 3 m/s^2, for 0.3 s.
  streams.extra_up = [](double t) {
    return t >= 15.0 && t < 15.3 ? 3.0 * std::sin(2.0 * kPi * 10.0 * (t - 15.0)) : 0.0;
  };
  ImuHeight h{ImuHeightOptions{}};
  EXPECT_NEAR(run(
                  h, 40.0, [](double) { return Motion{}; }, streams),
              0.0, 0.02);
}

TEST(ImuHeight, ALevelShiftWhileStandingIsDropped) {
  Streams streams;
  // The robot is nudged onto a tilt, or the bias steps: the vertical force drops for good.
  streams.extra_up = [](double t) { return t >= 15.0 ? -0.2 : 0.0; };
  ImuHeight h{ImuHeightOptions{}};
  EXPECT_NEAR(run(
                  h, 60.0, [](double) { return Motion{}; }, streams),
              0.0, 0.05);
}

// Stand, drive level, climb a 30 degree flight along the ground, drive level, stand.
Motion stairs(double t) {
  Motion m;
  const double v = 0.25;
  if (t < 5.0) return m;
  const double u = t - 5.0;
  if (u < 20.0) {
    m.s = v * u;
    m.v = v;
    m.pitch = (u >= 4.0 && u < 14.0) ? 30.0 * kPi / 180.0 : 0.0;
    return m;
  }
  m.s = v * 20.0;
  return m;
}

TEST(ImuHeight, StairsAreClimbedFromPitchAndDistance) {
  ImuHeight h{ImuHeightOptions{}};
  const double height = run(h, 35.0, stairs);
  // 2.5 m along a 30 degree slope.
  EXPECT_NEAR(height, 1.25, 0.06);
  // The stated uncertainty holds the wheels' distance error (5 % of it by default).
  const double sigma = std::sqrt(h.variance(0.0, 35.0));
  EXPECT_GE(sigma, 0.05 * 1.2);
  EXPECT_LT(sigma, 0.1);
}

TEST(ImuHeight, DrivingOnTheLevelWithATiltedMountingKeepsTheHeight) {
  Streams streams;
  streams.bias.x() += kG * std::sin(1.0 * kPi / 180.0);  // mounted 1 degree nose up
  ImuHeight h{ImuHeightOptions{}};
  const double height = run(
      h, 100.0,
      [](double t) {
        Motion m;
        if (t < 5.0) return m;
        // Speed 0.3 to 0.9 m/s, changing smoothly.
        const double u = t - 5.0;
        m.v = 0.6 + 0.3 * std::sin(0.2 * u);
        m.s = 0.6 * u - 1.5 * (std::cos(0.2 * u) - 1.0);
        m.a = 0.06 * std::cos(0.2 * u);
        return m;
      },
      streams);
  EXPECT_NEAR(height, 0.0, 0.05);
}

TEST(ImuHeight, AGapInTheSamplesMakesTheHeightAcrossItUnknown) {
  // The IMU is silent for 8 s of a 12 m ride: nothing tells how far the cabin went.
  Streams streams;
  streams.gap_from = 14.0;
  streams.gap_to = 22.0;
  ImuHeight h{ImuHeightOptions{}};
  run(
      h, 60.0,
      [](double t) {
        return Motion{0.0, 0.0, 0.0, 0.0, cabinAcceleration(t, 10.0, 12.0)};
      },
      streams);
  EXPECT_TRUE(std::isinf(h.variance(10.0, 30.0)));
  EXPECT_EQ(h.variance(0.0, 9.0), 0.0);    // before it, standing
  EXPECT_EQ(h.variance(40.0, 60.0), 0.0);  // after it, standing
  // A sample period's jitter is no gap.
  Streams jitter;
  jitter.gap_from = 30.0;
  jitter.gap_to = 30.3;
  ImuHeight j{ImuHeightOptions{}};
  run(
      j, 60.0, [](double) { return Motion{}; }, jitter);
  EXPECT_EQ(j.variance(0.0, 60.0), 0.0);
}

}  // namespace
}  // namespace storey::detection
