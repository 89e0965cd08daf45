#include "storey/detection/floor_detector.h"

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <limits>
#include <sstream>

#include "storey/common/log.h"
#include "synthetic_ride.h"
#include "test_support.h"

namespace storey::detection {
namespace {

using test::ended;
using test::Script;
using test::SensorSetup;
using test::shippedOptions;

SensorSetup barometerOnly(unsigned seed = 1) {
  SensorSetup s;
  s.imu = s.odometry = s.scans = false;
  s.seed = seed;
  return s;
}

TEST(Barometer, HypsometricHeightIsNotLinearInPressure) {
  const double T = 288.15;
  // Near sea level a storey is ~36 Pa, about 12 Pa/m.
  const double p0 = 101325.0;
  const double p3 = pressureAtHeight(3.0, T, p0);
  EXPECT_NEAR(p0 - p3, 36.0, 1.0);
  EXPECT_NEAR(heightDifference(p0, p3, T), 3.0, 1e-9);
  EXPECT_NEAR(pressureHeight(p3, T, p0), 3.0, 1e-9);
  // At 3000 m the same storey is fewer pascals: a constant 12 Pa/m would be 25 % off.
  const double high = pressureAtHeight(3000.0, T, p0);
  const double high3 = pressureAtHeight(3003.0, T, p0);
  EXPECT_LT(high - high3, 0.75 * (p0 - p3));
  EXPECT_NEAR(heightDifference(high, high3, T), 3.0, 1e-9);
  // The height scale follows the temperature.
  EXPECT_NEAR(heightDifference(p0, p3, 1.1 * T), 3.3, 1e-9);
}

TEST(Barometer, DerivativeMatchesNumeric) {
  const double T = 290.0;
  const Eigen::VectorXd x = Eigen::VectorXd::Constant(1, 95000.0);
  const Eigen::MatrixXd J = storey::test::numericJacobian(
      [&](const Eigen::VectorXd& p) {
        return Eigen::VectorXd::Constant(1, pressureHeight(p(0), T));
      },
      x, 1e-2);
  // dh/dp = -H / p.
  EXPECT_NEAR(J(0, 0), -scaleHeight(T) / 95000.0, 1e-7);
}

TEST(FloorDetectorOptions, ShippedFileLoadsStrictly) {
  const FloorDetectorOptions o = shippedOptions();
  EXPECT_DOUBLE_EQ(o.barometer.temperature_kelvin, 288.15);
  EXPECT_TRUE(o.floors.heights.empty());
  EXPECT_TRUE(o.sensors.imu);
}

// `storey floors` without --config uses the struct's defaults: they must be the file's.
TEST(FloorDetectorOptions, DefaultsEqualTheShippedFile) {
  const FloorDetectorOptions f = shippedOptions();
  const FloorDetectorOptions d;
  EXPECT_EQ(f.barometer.temperature_kelvin, d.barometer.temperature_kelvin);
  EXPECT_EQ(f.barometer.temperature_uncertainty_kelvin, d.barometer.temperature_uncertainty_kelvin);
  EXPECT_EQ(f.barometer.min_pressure, d.barometer.min_pressure);
  EXPECT_EQ(f.barometer.max_pressure, d.barometer.max_pressure);
  EXPECT_EQ(f.barometer.median_window, d.barometer.median_window);
  EXPECT_EQ(f.barometer.velocity_window, d.barometer.velocity_window);
  EXPECT_EQ(f.barometer.max_gap, d.barometer.max_gap);
  EXPECT_EQ(f.barometer.max_drift_rate, d.barometer.max_drift_rate);
  EXPECT_EQ(f.transit.start_velocity, d.transit.start_velocity);
  EXPECT_EQ(f.transit.end_velocity, d.transit.end_velocity);
  EXPECT_EQ(f.transit.min_duration, d.transit.min_duration);
  EXPECT_EQ(f.transit.min_start_change, d.transit.min_start_change);
  EXPECT_EQ(f.transit.settle_time, d.transit.settle_time);
  EXPECT_EQ(f.transit.new_floor_settle_time, d.transit.new_floor_settle_time);
  EXPECT_EQ(f.transit.reference_window, d.transit.reference_window);
  EXPECT_EQ(f.floors.storey_height, d.floors.storey_height);
  EXPECT_EQ(f.floors.min_change_fraction, d.floors.min_change_fraction);
  EXPECT_EQ(f.floors.match_tolerance, d.floors.match_tolerance);
  EXPECT_EQ(f.floors.heights, d.floors.heights);
  EXPECT_EQ(f.floors.initial_floor, d.floors.initial_floor);
  EXPECT_EQ(f.sensors.barometer, d.sensors.barometer);
  EXPECT_EQ(f.imu.accel_noise_density, d.imu.accel_noise_density);
  EXPECT_EQ(f.imu.accel_bias_walk, d.imu.accel_bias_walk);
  EXPECT_EQ(f.imu.odometry_translation_per_meter, d.imu.odometry_translation_per_meter);
  EXPECT_EQ(f.imu.stationary_speed, d.imu.stationary_speed);
  EXPECT_EQ(f.imu.cabin_min_speed, d.imu.cabin_min_speed);
  EXPECT_EQ(f.sensors.imu, d.sensors.imu);
  EXPECT_EQ(f.sensors.odometry, d.sensors.odometry);
  EXPECT_EQ(f.sensors.scan, d.sensors.scan);
  EXPECT_EQ(f.corroboration.elevator_min_speed, d.corroboration.elevator_min_speed);
  EXPECT_EQ(f.corroboration.stairs_max_speed, d.corroboration.stairs_max_speed);
  EXPECT_EQ(f.corroboration.stationary_speed, d.corroboration.stationary_speed);
  EXPECT_EQ(f.corroboration.max_planar_speed, d.corroboration.max_planar_speed);
  EXPECT_EQ(f.corroboration.static_scan_similarity, d.corroboration.static_scan_similarity);
  EXPECT_EQ(f.corroboration.moving_scan_similarity, d.corroboration.moving_scan_similarity);
  EXPECT_EQ(f.corroboration.scan.absolute_tolerance, d.corroboration.scan.absolute_tolerance);
  EXPECT_EQ(f.corroboration.scan.relative_tolerance, d.corroboration.scan.relative_tolerance);
}

TEST(FloorDetectorOptions, UnknownKeyAndBadValuesNameTheKey) {
  const std::string path = storey::test::sourceDir() + "/config/floor_detector.yaml";
  std::ifstream in(path);
  std::stringstream buffer;
  buffer << in.rdbuf();
  const std::string text = buffer.str();
  auto load = [](const std::string& t) {
    const auto root = common::ConfigNode::loadString(t, "fd.yaml");
    return readFloorDetectorOptions(root.child("detector"));
  };
  EXPECT_NO_THROW(load(text));
  std::string unknown = text;
  unknown.replace(unknown.find("    max_gap:"), 0, "    max_gapp: 2.0\n");
  try {
    load(unknown);
    FAIL() << "unknown key accepted";
  } catch (const common::ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("max_gapp"), std::string::npos) << e.what();
    EXPECT_EQ(e.file(), "fd.yaml");
  }
  std::string bad = text;
  const auto at = bad.find("end_velocity: 0.03");
  bad.replace(at, std::string("end_velocity: 0.03").size(), "end_velocity: 0.5");
  try {
    load(bad);
    FAIL() << "end_velocity above start_velocity accepted";
  } catch (const common::ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("end_velocity"), std::string::npos) << e.what();
    EXPECT_GT(e.line(), 1);
  }
  std::string heights = text;
  heights.replace(heights.find("heights: []"), std::string("heights: []").size(),
                  "heights: [0.0, 4.0, 3.0]");
  EXPECT_THROW(load(heights), common::ConfigError);
  // Neither a barometer nor an IMU: nothing to detect floor changes from.
  std::string neither = text;
  neither.replace(neither.find("barometer: true"), 15, "barometer: false");
  neither.replace(neither.find("    imu: true"), 13, "    imu: false");
  try {
    load(neither);
    FAIL() << "a robot without barometer and IMU accepted";
  } catch (const common::ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("sensors.barometer"), std::string::npos) << e.what();
  }
}

TEST(FloorDetector, TwoHoursOfWeatherDriftOnOneFloorChangeNothing) {
  common::setLogLevel(common::LogLevel::kWarn);
  for (double drift : {100.0, -100.0}) {  // 1 hPa per hour: ~8 m of apparent height
    FloorDetector detector(shippedOptions());
    Script script;
    for (int i = 0; i < 60; ++i) script.wait(60.0).drive(60.0);
    SensorSetup setup = barometerOnly(7);
    setup.drift_pa_per_hour = drift;
    const auto events = test::run(script, setup, detector);
    EXPECT_TRUE(events.empty()) << events.size() << " events, first at t=" << events[0].stamp;
    EXPECT_EQ(detector.currentFloor(), 0);
    EXPECT_EQ(detector.floors().size(), 1u);
  }
}

TEST(FloorDetector, OneFloorElevatorRideInFourSecondsWithBarometerOnly) {
  for (unsigned seed : {1u, 2u, 3u}) {
    FloorDetector detector(shippedOptions());
    Script script;
    script.wait(30.0).elevator(3.0).wait(30.0);
    // The profile: 1 m/s at 0.5 m/s^2 covers 3 m in 4 s.
    const auto events = test::run(script, barometerOnly(seed), detector);
    ASSERT_EQ(events.size(), 2u) << "seed " << seed;
    EXPECT_EQ(events[0].type, FloorEventType::kTransitStarted);
    const FloorEvent& end = events[1];
    EXPECT_EQ(end.type, FloorEventType::kTransitEnded);
    EXPECT_TRUE(end.floor_changed);
    EXPECT_TRUE(end.new_floor);
    EXPECT_EQ(end.from_floor, 0);
    EXPECT_EQ(end.floor_id, 1);
    EXPECT_NEAR(end.height_change, 3.0, 0.2);
    EXPECT_GT(end.height_change_stddev, 0.0);
    EXPECT_LT(end.height_change_stddev, 0.3);
    EXPECT_EQ(end.mode, TransitMode::kElevator);
    // The reported interval contains the ride (32 s .. 36 s).
    EXPECT_LE(events[0].stamp, 32.0);
    EXPECT_GT(events[0].stamp, 26.0);
    EXPECT_GE(end.stamp, 36.0);
    EXPECT_LT(end.stamp, 42.0);
    EXPECT_EQ(detector.currentFloor(), 1);
    EXPECT_FALSE(detector.inTransit());
  }
}

TEST(FloorDetector, CorroborationRaisesConfidenceAndKeepsTheMode) {
  Script script;
  script.wait(30.0).elevator(3.0).wait(30.0);
  FloorDetector alone(shippedOptions());
  const auto baro = ended(test::run(script, barometerOnly(4), alone));
  FloorDetector all(shippedOptions());
  SensorSetup full;
  full.seed = 4;
  const auto fused = ended(test::run(script, full, all));
  ASSERT_EQ(baro.size(), 1u);
  ASSERT_EQ(fused.size(), 1u);
  EXPECT_GT(fused[0].confidence, baro[0].confidence + 0.05);
  EXPECT_GT(fused[0].confidence, 0.9);
  EXPECT_EQ(fused[0].mode, TransitMode::kElevator);
  EXPECT_NEAR(fused[0].height_change, 3.0, 0.2);
}

TEST(FloorDetector, StairsWithALandingAreOneFloorChange) {
  for (unsigned seed : {1u, 2u, 3u}) {
    FloorDetector detector(shippedOptions());
    Script script;
    script.wait(20.0).drive(10.0).stairs(3.0).drive(20.0).wait(20.0);
    SensorSetup setup;
    setup.seed = seed;
    const auto events = test::run(script, setup, detector);
    const auto ends = ended(events);
    ASSERT_EQ(events.size(), 2u) << "seed " << seed;
    ASSERT_EQ(ends.size(), 1u);
    EXPECT_EQ(ends[0].floor_id, 1);
    EXPECT_NEAR(ends[0].height_change, 3.0, 0.2);
    EXPECT_EQ(ends[0].mode, TransitMode::kStairs);
  }
}

TEST(FloorDetector, ALongStopOnTheHalfLandingStillAddsUpToOneStorey) {
  FloorDetector detector(shippedOptions());
  Script script;
  script.wait(20.0).stairs(3.0, 4.0, 40.0).wait(30.0);
  const auto ends = ended(test::run(script, barometerOnly(12), detector));
  ASSERT_FALSE(ends.empty());
  // The landing itself may be reported as "no change"; the floor reached is one storey up.
  for (std::size_t i = 0; i + 1 < ends.size(); ++i) EXPECT_FALSE(ends[i].floor_changed);
  EXPECT_TRUE(ends.back().floor_changed);
  EXPECT_EQ(ends.back().floor_id, 1);
  EXPECT_NEAR(ends.back().floor_height, 3.0, 0.2);
  EXPECT_NEAR(ends.back().height_change, 3.0, 0.2);
  EXPECT_EQ(detector.floors().size(), 2u);
}

TEST(FloorDetector, StairsDownWithBarometerOnly) {
  FloorDetector detector(shippedOptions());
  Script script;
  script.wait(20.0).stairs(-3.5).wait(30.0);
  const auto ends = ended(test::run(script, barometerOnly(5), detector));
  ASSERT_EQ(ends.size(), 1u);
  EXPECT_EQ(ends[0].floor_id, 1);
  EXPECT_NEAR(ends[0].floor_height, -3.5, 0.2);
  EXPECT_NEAR(ends[0].height_change, -3.5, 0.2);
}

TEST(FloorDetector, ReturningToAKnownFloorResumesItsId) {
  FloorDetector detector(shippedOptions());
  Script script;
  script.wait(20.0).elevator(3.0).wait(40.0).elevator(3.2).wait(40.0);
  script.elevator(-6.2).wait(40.0).elevator(3.0).wait(30.0).stairs(3.2).wait(30.0);
  SensorSetup setup;
  setup.drift_pa_per_hour = 80.0;
  setup.seed = 11;
  const auto ends = ended(test::run(script, setup, detector));
  ASSERT_EQ(ends.size(), 5u);
  const int expected[] = {1, 2, 0, 1, 2};
  const bool created[] = {true, true, false, false, false};
  for (int i = 0; i < 5; ++i) {
    EXPECT_EQ(ends[i].floor_id, expected[i]) << "ride " << i;
    EXPECT_EQ(ends[i].new_floor, created[i]) << "ride " << i;
  }
  EXPECT_EQ(detector.floors().size(), 3u);
  EXPECT_NEAR(detector.floors()[2].height, 6.2, 0.2);
  EXPECT_EQ(ends[4].mode, TransitMode::kStairs);
}

TEST(FloorDetector, ConfiguredFloorHeightsGiveIdsAndSkipStoreys) {
  FloorDetectorOptions o = shippedOptions();
  o.floors.heights = {-3.0, 0.0, 4.5, 8.0, 11.5};
  o.floors.initial_floor = 1;
  FloorDetector detector(o);
  EXPECT_EQ(detector.currentFloor(), 1);
  Script script;
  script.wait(20.0).elevator(8.0).wait(30.0).elevator(-11.0).wait(30.0);
  const auto ends = ended(test::run(script, barometerOnly(3), detector));
  ASSERT_EQ(ends.size(), 2u);
  EXPECT_EQ(ends[0].floor_id, 3);
  EXPECT_DOUBLE_EQ(ends[0].floor_height, 8.0);
  EXPECT_FALSE(ends[0].new_floor);
  EXPECT_EQ(ends[1].floor_id, 0);
  EXPECT_EQ(detector.floors().size(), 5u);
}

TEST(FloorDetector, DoorSlamSpikesAreIgnored) {
  FloorDetector detector(shippedOptions());
  Script script;
  script.wait(300.0);
  SensorSetup setup = barometerOnly(9);
  // Every 20 s a door slams: +40 Pa (~3 m) for 0.3 s, then -25 Pa for 0.2 s.
  setup.tamper = [](double t, double& p) {
    const double phase = std::fmod(t, 20.0);
    if (phase >= 10.0 && phase < 10.3) p += 40.0;
    if (phase >= 10.3 && phase < 10.5) p -= 25.0;
    return true;
  };
  const auto events = test::run(script, setup, detector);
  EXPECT_TRUE(events.empty());
  EXPECT_EQ(detector.currentFloor(), 0);
}

TEST(FloorDetector, GapsOnAFloorAreLoggedNotFloors) {
  FloorDetector detector(shippedOptions());
  Script script;
  script.wait(200.0);
  SensorSetup setup = barometerOnly(2);
  setup.tamper = [](double t, double&) {
    return !(t > 50.0 && t < 58.0) && !(t > 120 && t < 121.5);
  };
  const auto events = test::run(script, setup, detector);
  EXPECT_TRUE(events.empty());
  EXPECT_EQ(detector.stats().gaps, 2u);
  EXPECT_EQ(detector.currentFloor(), 0);
}

TEST(FloorDetector, ARideHiddenInAGapIsStillFound) {
  FloorDetector detector(shippedOptions());
  Script script;
  script.wait(40.0).elevator(3.0).wait(40.0);
  SensorSetup setup = barometerOnly(2);
  setup.tamper = [](double t, double&) { return !(t > 38.0 && t < 50.0); };
  const auto events = test::run(script, setup, detector);
  ASSERT_EQ(events.size(), 2u);
  EXPECT_EQ(events[0].type, FloorEventType::kTransitStarted);
  EXPECT_EQ(events[1].floor_id, 1);
  EXPECT_NEAR(events[1].height_change, 3.0, 0.3);
  EXPECT_LT(events[1].confidence, 0.7);  // nobody saw the ride itself
}

TEST(FloorDetector, BadSamplesAreRejectedAndCounted) {
  FloorDetector detector(shippedOptions());
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  EXPECT_TRUE(detector.addPressure({1.0, 101325.0, 0.0}));
  EXPECT_FALSE(detector.addPressure({1.1, nan, 0.0}));
  EXPECT_FALSE(detector.addPressure({1.2, inf, 0.0}));
  EXPECT_FALSE(detector.addPressure({1.3, -5.0, 0.0}));
  EXPECT_FALSE(detector.addPressure({nan, 101325.0, 0.0}));
  EXPECT_FALSE(detector.addPressure({0.5, 101325.0, 0.0}));  // out of order
  EXPECT_FALSE(detector.addPressure({1.0, 101325.0, 0.0}));  // duplicate stamp
  EXPECT_TRUE(detector.addPressure({1.4, 101325.0, 0.0}));
  EXPECT_EQ(detector.stats().rejected_pressure, 6u);
  sensor::ImuSample imu;
  imu.stamp = 1.0;
  imu.linear_acceleration = Eigen::Vector3d(0, 0, nan);
  EXPECT_FALSE(detector.addImu(imu));
  sensor::OdometrySample odom;
  odom.stamp = nan;
  EXPECT_FALSE(detector.addOdometry(odom));
  sensor::LaserScan scan;  // no beams
  scan.stamp = 1.0;
  EXPECT_FALSE(detector.addScan(scan));
  EXPECT_EQ(detector.stats().rejected_other, 3u);
}

TEST(FloorDetector, NaNBurstsDuringARideDoNotBreakIt) {
  FloorDetector detector(shippedOptions());
  Script script;
  script.wait(30.0).elevator(6.0).wait(40.0);
  SensorSetup setup = barometerOnly(6);
  setup.tamper = [](double t, double& p) {
    if (std::fmod(t, 7.0) < 0.35) p = std::numeric_limits<double>::quiet_NaN();
    return true;
  };
  const auto ends = ended(test::run(script, setup, detector));
  ASSERT_EQ(ends.size(), 1u);
  EXPECT_NEAR(ends[0].height_change, 6.0, 0.25);
  EXPECT_GT(detector.stats().rejected_pressure, 10u);
}

TEST(FloorDetector, ARampIsNotAFloor) {
  FloorDetector detector(shippedOptions());
  Script script;
  script.wait(30.0).stairs(1.0, 1.0, 2.0).wait(40.0);
  const auto events = test::run(script, barometerOnly(8), detector);
  for (const auto& e : events) {
    if (e.type == FloorEventType::kTransitEnded) {
      EXPECT_FALSE(e.floor_changed);
      EXPECT_EQ(e.floor_id, 0);
    }
  }
  EXPECT_EQ(detector.currentFloor(), 0);
  EXPECT_EQ(detector.floors().size(), 1u);
}

TEST(ScanSimilarity, IdenticalShiftedAndIncompatible) {
  std::mt19937 rng(1);
  const auto a = test::boxScan(0.0, 0.0, -0.8, 0.8, -0.8, 0.8, rng);
  const auto b = test::boxScan(0.1, 0.0, -0.8, 0.8, -0.8, 0.8, rng);
  EXPECT_GT(scanSimilarity(a, b), 0.95);
  // Moving 1.5 m along a stairwell changes every beam that meets its end wall.
  const auto c = test::boxScan(0.2, 0.5, -1.0, 3.0, -1.0, 1.0, rng);
  const auto d = test::boxScan(0.3, 2.0, -1.0, 3.0, -1.0, 1.0, rng);
  EXPECT_LT(scanSimilarity(c, d), 0.8);
  EXPECT_GT(scanSimilarity(c, d), 0.2);  // the side walls still agree
  auto e = a;
  e.ranges.pop_back();
  EXPECT_LT(scanSimilarity(a, e), 0.0);
}

}  // namespace
}  // namespace storey::detection
