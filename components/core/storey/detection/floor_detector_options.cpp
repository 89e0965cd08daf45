#include "storey/detection/floor_detector_options.h"

#include <cmath>

namespace storey::detection {

namespace {
constexpr double kUnbounded = std::numeric_limits<double>::infinity();
}

FloorDetectorOptions readFloorDetectorOptions(const common::ConfigNode& node) {
  FloorDetectorOptions o;
  {
    const common::ConfigNode n = node.child("sensors");
    o.sensors.barometer = n.get<bool>("barometer");
    o.sensors.imu = n.get<bool>("imu");
    o.sensors.odometry = n.get<bool>("odometry");
    o.sensors.scan = n.get<bool>("scan");
    if (!o.sensors.barometer && !o.sensors.imu) {
      n.fail("barometer", "a robot needs a barometer or an IMU to detect floor changes");
    }
    n.finish();
  }
  {
    const common::ConfigNode n = node.child("imu");
    o.imu.accel_noise_density = n.getDouble("accel_noise_density", 1e-6, 10.0);
    o.imu.accel_bias_walk = n.getDouble("accel_bias_walk", 0.0, 10.0);
    n.finish();
  }
  {
    const common::ConfigNode n = node.child("odometry");
    o.imu.odometry_translation_per_meter = n.getDouble("translation_per_meter", 0.0, 1.0);
    n.finish();
  }
  {
    const common::ConfigNode b = node.child("barometer");
    o.barometer.temperature_kelvin = b.getDouble("temperature_kelvin", 150.0, 350.0);
    o.barometer.temperature_uncertainty_kelvin =
        b.getDouble("temperature_uncertainty_kelvin", 0.0, 100.0);
    o.barometer.min_pressure = b.getDouble("min_pressure", 0.0, kUnbounded);
    o.barometer.max_pressure = b.getDouble("max_pressure", 0.0, kUnbounded);
    if (o.barometer.max_pressure <= o.barometer.min_pressure) {
      b.fail("max_pressure", "must exceed min_pressure");
    }
    o.barometer.median_window = b.getDouble("median_window", 0.0, 30.0);
    o.barometer.velocity_window = b.getDouble("velocity_window", 0.1, 30.0);
    o.barometer.max_gap = b.getDouble("max_gap", 0.01, 3600.0);
    o.barometer.max_drift_rate = b.getDouble("max_drift_rate", 0.0, 10000.0);
    b.finish();
  }
  {
    const common::ConfigNode t = node.child("transit");
    o.transit.start_velocity = t.getDouble("start_velocity", 1e-3, 100.0);
    o.transit.end_velocity = t.getDouble("end_velocity", 1e-3, 100.0);
    if (o.transit.end_velocity > o.transit.start_velocity) {
      t.fail("end_velocity", "must not exceed start_velocity");
    }
    o.transit.min_duration = t.getDouble("min_duration", 0.0, 600.0);
    o.transit.min_start_change = t.getDouble("min_start_change", 0.0, 100.0);
    o.transit.settle_time = t.getDouble("settle_time", 0.1, 600.0);
    o.transit.new_floor_settle_time = t.getDouble("new_floor_settle_time", 0.1, 600.0);
    if (o.transit.new_floor_settle_time < o.transit.settle_time) {
      t.fail("new_floor_settle_time", "must be at least settle_time");
    }
    o.transit.reference_window = t.getDouble("reference_window", 0.1, 600.0);
    t.finish();
  }
  {
    const common::ConfigNode f = node.child("floors");
    o.floors.storey_height = f.getDouble("storey_height", 0.5, 100.0);
    o.floors.min_change_fraction = f.getDouble("min_change_fraction", 0.05, 1.0);
    o.floors.match_tolerance = f.getDouble("match_tolerance", 0.01, 100.0);
    o.floors.heights = f.getDoubles("heights");
    for (std::size_t i = 0; i < o.floors.heights.size(); ++i) {
      if (!std::isfinite(o.floors.heights[i])) f.fail("heights", "values must be finite");
      if (i > 0 && o.floors.heights[i] <= o.floors.heights[i - 1]) {
        f.fail("heights", "must be strictly increasing");
      }
    }
    const int max_index = o.floors.heights.empty() ? 0 : int(o.floors.heights.size()) - 1;
    o.floors.initial_floor = f.getInt("initial_floor", 0, max_index);
    f.finish();
  }
  {
    const common::ConfigNode c = node.child("corroboration");
    o.corroboration.elevator_min_speed = c.getDouble("elevator_min_speed", 0.0, 100.0);
    o.corroboration.stairs_max_speed = c.getDouble("stairs_max_speed", 0.0, 100.0);
    o.corroboration.stationary_speed = c.getDouble("stationary_speed", 0.0, 100.0);
    o.corroboration.max_planar_speed = c.getDouble("max_planar_speed", 0.0, 100.0);
    o.corroboration.static_scan_similarity = c.getDouble("static_scan_similarity", 0.0, 1.0);
    o.corroboration.moving_scan_similarity = c.getDouble("moving_scan_similarity", 0.0, 1.0);
    o.corroboration.scan.absolute_tolerance = c.getDouble("scan_absolute_tolerance", 0.0, 10.0);
    o.corroboration.scan.relative_tolerance = c.getDouble("scan_relative_tolerance", 0.0, 1.0);
    c.finish();
  }
  o.imu.stationary_speed = o.corroboration.stationary_speed;
  o.imu.cabin_min_speed = o.corroboration.elevator_min_speed;
  node.finish();
  return o;
}

FloorDetectorOptions loadFloorDetectorOptions(const std::string& path) {
  const common::ConfigNode root = common::ConfigNode::loadFile(path);
  return readFloorDetectorOptions(root.child("detector"));
}

}  // namespace storey::detection
