// Synthetic sensor streams for floor-detector tests: a script of waits, drives, elevator
// rides and stair climbs becomes barometer, IMU, odometry and scan samples with noise
// from a fixed seed, fed to a detector in time order.
#pragma once

#include <algorithm>
#include <cmath>
#include <functional>
#include <random>
#include <vector>

#include "storey/detection/barometer.h"
#include "storey/detection/floor_detector.h"
#include "test_support.h"

namespace storey::detection::test {

inline FloorDetectorOptions shippedOptions() {
  return loadFloorDetectorOptions(storey::test::sourceDir() + "/config/floor_detector.yaml");
}

struct SensorSetup {
  double pressure_rate = 10.0;  // Hz
  double pressure_sigma = 3.0;  // Pa
  double drift_pa_per_hour = 0.0;
  double temperature_kelvin = 288.15;
  bool imu = true;
  double imu_rate = 50.0;
  double accel_sigma = 0.05;
  bool odometry = true;
  double odom_rate = 20.0;
  bool scans = true;
  double scan_rate = 5.0;
  unsigned seed = 1;
  // Optional tampering with the pressure stream: return false to drop a sample.
  std::function<bool(double t, double& pascal)> tamper;
  // Optional: called with each event as it comes out (a floor mapper answering).
  std::function<void(FloorDetector&, const FloorEvent&)> on_event;
};

class Script {
 public:
  struct Piece {
    enum Kind { kWait, kDrive, kElevator, kStairs } kind;
    double t0, t1, z0, dz, speed;
    double accel = 0.5, vmax = 1.0;
  };

  Script& wait(double seconds) { return push({Piece::kWait, t_, t_ + seconds, z_, 0.0, 0.0}); }
  Script& drive(double seconds, double speed = 0.6) {
    return push({Piece::kDrive, t_, t_ + seconds, z_, 0.0, speed});
  }
  // Doors close (2 s), the cabin moves with a trapezoid profile, doors open (2 s).
  Script& elevator(double dz, double vmax = 1.0, double accel = 0.5) {
    wait(2.0);
    const double d = std::abs(dz);
    double ta = vmax / accel, tc = 0.0;
    if (d >= vmax * vmax / accel) {
      tc = (d - vmax * vmax / accel) / vmax;
    } else {
      ta = std::sqrt(d / accel);
    }
    Piece p{Piece::kElevator, t_, t_ + 2 * ta + tc, z_, dz, 0.0, accel, accel * ta};
    push(p);
    cabin_.push_back({p.t0 - 2.0, p.t1 + 2.0});
    return wait(2.0);
  }
  // Planar speed 0.25 m/s; two flights with a landing between them (turn, cross, turn).
  Script& stairs(double dz, double flight_run = 4.0, double landing_seconds = 8.0) {
    const double flight_time = flight_run / 0.25;
    push({Piece::kStairs, t_, t_ + flight_time, z_, dz / 2.0, 0.25});
    drive(landing_seconds, 0.1);
    return push({Piece::kStairs, t_, t_ + flight_time, z_, dz / 2.0, 0.25});
  }

  double duration() const { return t_; }
  double z(double t) const { return eval(t).z; }

  struct State {
    double z = 0.0, az = 0.0, planar_speed = 0.0;
    bool cabin = false;
  };
  State eval(double t) const {
    State s;
    s.z = z_;
    for (const auto& p : pieces_) {
      if (t < p.t0) break;
      if (t >= p.t1) {
        s.z = p.z0 + p.dz;
        continue;
      }
      const double tau = t - p.t0;
      s.z = p.z0;
      if (p.kind == Piece::kDrive) s.planar_speed = p.speed;
      if (p.kind == Piece::kStairs) {
        s.planar_speed = p.speed;
        s.z = p.z0 + p.dz * tau / (p.t1 - p.t0);
      }
      if (p.kind == Piece::kElevator) {
        const double sign = p.dz > 0 ? 1.0 : -1.0;
        const double T = p.t1 - p.t0, ta = p.vmax / p.accel, tc = T - 2 * ta;
        double z = 0.0;
        if (tau < ta) {
          z = 0.5 * p.accel * tau * tau;
          s.az = sign * p.accel;
        } else if (tau < ta + tc) {
          z = 0.5 * p.accel * ta * ta + p.vmax * (tau - ta);
        } else {
          z = std::abs(p.dz) - 0.5 * p.accel * (T - tau) * (T - tau);
          s.az = -sign * p.accel;
        }
        s.z = p.z0 + sign * z;
      }
      break;
    }
    for (const auto& c : cabin_) s.cabin = s.cabin || (t >= c.first && t <= c.second);
    return s;
  }

 private:
  Script& push(const Piece& p) {
    pieces_.push_back(p);
    t_ = p.t1;
    z_ = p.z0 + p.dz;
    return *this;
  }
  std::vector<Piece> pieces_;
  std::vector<std::pair<double, double>> cabin_;
  double t_ = 0.0, z_ = 0.0;
};

// Ranges from (x, 0) heading +x to the walls of the box [x0, x1] x [y0, y1].
inline sensor::LaserScan boxScan(double stamp, double x, double x0, double x1, double y0, double y1,
                                 std::mt19937& rng) {
  sensor::LaserScan scan;
  scan.stamp = stamp;
  scan.angle_min = -M_PI / 2;
  scan.angle_increment = M_PI / 90;
  scan.range_min = 0.05;
  scan.range_max = 30.0;
  std::normal_distribution<double> noise(0.0, 0.01);
  for (int i = 0; i <= 90; ++i) {
    const double a = scan.angle(i);
    const double c = std::cos(a), s = std::sin(a);
    double r = 1e9;
    if (c > 1e-9) r = std::min(r, (x1 - x) / c);
    if (c < -1e-9) r = std::min(r, (x0 - x) / c);
    if (s > 1e-9) r = std::min(r, y1 / s);
    if (s < -1e-9) r = std::min(r, y0 / s);
    scan.ranges.push_back(static_cast<float>(std::min(r + noise(rng), 29.9)));
  }
  return scan;
}

// Feeds the script's sensor streams to `detector` in time order; returns all events.
inline std::vector<FloorEvent> run(const Script& script, const SensorSetup& setup,
                                   FloorDetector& detector) {
  std::mt19937 rng(setup.seed);
  std::normal_distribution<double> unit(0.0, 1.0);
  struct Tick {
    double t;
    int stream;
  };
  std::vector<Tick> ticks;
  auto add = [&](double rate, int stream) {
    for (int i = 0; i * (1.0 / rate) <= script.duration(); ++i) ticks.push_back({i / rate, stream});
  };
  add(setup.pressure_rate, 0);
  if (setup.imu) add(setup.imu_rate, 1);
  if (setup.odometry) add(setup.odom_rate, 2);
  if (setup.scans) add(setup.scan_rate, 3);
  std::stable_sort(ticks.begin(), ticks.end(),
                   [](const Tick& a, const Tick& b) { return a.t < b.t; });
  std::vector<FloorEvent> events;
  double x = 0.0, last_odom = 0.0;
  for (const auto& tick : ticks) {
    const auto s = script.eval(tick.t);
    if (tick.stream == 0) {
      const double p0 = kReferencePressure + setup.drift_pa_per_hour / 3600.0 * tick.t;
      double pascal =
          pressureAtHeight(s.z, setup.temperature_kelvin, p0) + setup.pressure_sigma * unit(rng);
      if (setup.tamper && !setup.tamper(tick.t, pascal)) continue;
      detector.addPressure({tick.t, pascal, setup.pressure_sigma * setup.pressure_sigma});
    } else if (tick.stream == 1) {
      sensor::ImuSample imu;
      imu.stamp = tick.t;
      imu.linear_acceleration =
          Eigen::Vector3d(setup.accel_sigma * unit(rng), setup.accel_sigma * unit(rng),
                          kStandardGravity + s.az + setup.accel_sigma * unit(rng));
      detector.addImu(imu);
    } else if (tick.stream == 2) {
      x += s.planar_speed * (tick.t - last_odom);
      last_odom = tick.t;
      sensor::OdometrySample odom;
      odom.stamp = tick.t;
      odom.pose = geometry::Pose2(x, 0.0, 0.0);
      odom.linear_velocity = s.planar_speed;
      detector.addOdometry(odom);
    } else {
      // In a cabin the walls move with the robot; elsewhere a long corridor.
      const auto scan = s.cabin ? boxScan(tick.t, 0.0, -0.8, 0.8, -0.8, 0.8, rng)
                                : boxScan(tick.t, std::fmod(x, 20.0), -1.0, 25.0, -1.5, 1.5, rng);
      detector.addScan(scan);
    }
    for (auto events_now = detector.takeEvents(); !events_now.empty();
         events_now = detector.takeEvents()) {
      for (auto& e : events_now) {
        events.push_back(e);
        if (setup.on_event) setup.on_event(detector, e);  // may make more events
      }
    }
  }
  return events;
}

inline std::vector<FloorEvent> ended(const std::vector<FloorEvent>& events) {
  std::vector<FloorEvent> out;
  for (const auto& e : events) {
    if (e.type == FloorEventType::kTransitEnded) out.push_back(e);
  }
  return out;
}

}  // namespace storey::detection::test
