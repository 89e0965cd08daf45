// Options of the floor detector, read strictly from YAML (config/floor_detector.yaml).
#pragma once

#include <string>
#include <vector>

#include "storey/common/config.h"
#include "storey/common/shipped_config.h"
#include "storey/detection/imu_height.h"
#include "storey/detection/scan_similarity.h"

namespace storey::detection {

struct BarometerOptions {
  // air temperature for the hypsometric equation
  double temperature_kelvin = shipped_detector::barometer::temperature_kelvin;
  // scales the reported std-dev
  double temperature_uncertainty_kelvin =
      shipped_detector::barometer::temperature_uncertainty_kelvin;
  // Pa; readings outside are rejected
  double min_pressure = shipped_detector::barometer::min_pressure;
  // Pa
  double max_pressure = shipped_detector::barometer::max_pressure;
  // s; Hampel window: spikes (door slams) shorter than half of it go
  double median_window = shipped_detector::barometer::median_window;
  // s; least-squares slope of the filtered height
  double velocity_window = shipped_detector::barometer::velocity_window;
  // s; a longer silence restarts the filter
  double max_gap = shipped_detector::barometer::max_gap;
  // Pa/h of weather drift assumed for the std-dev
  double max_drift_rate = shipped_detector::barometer::max_drift_rate;
};

struct TransitOptions {
  // m/s; vertical speed that starts a candidate
  double start_velocity = shipped_detector::transit::start_velocity;
  // m/s; below it the robot is quiet
  double end_velocity = shipped_detector::transit::end_velocity;
  // s; a candidate must last this long
  double min_duration = shipped_detector::transit::min_duration;
  // m; and have moved this far from the floor
  double min_start_change = shipped_detector::transit::min_start_change;
  // s; quiet time to end a ride at a known floor
  double settle_time = shipped_detector::transit::settle_time;
  // s; quiet time to create a floor (or stay)
  double new_floor_settle_time = shipped_detector::transit::new_floor_settle_time;
  // s; on-floor height averaged before a ride
  double reference_window = shipped_detector::transit::reference_window;
};

struct FloorIdentityOptions {
  // m; nominal, for the minimum change
  double storey_height = shipped_detector::floors::storey_height;
  // of storey_height, to reach a new floor
  double min_change_fraction = shipped_detector::floors::min_change_fraction;
  // m; arrival within this of a known floor resumes it
  double match_tolerance = shipped_detector::floors::match_tolerance;
  std::vector<double> heights;        // building floor heights from config (may be empty)
  // index into heights (ignored when empty)
  int initial_floor = shipped_detector::floors::initial_floor;
};

struct CorroborationOptions {
  // m/s typical (median) vertical speed: elevator-like
  double elevator_min_speed = shipped_detector::corroboration::elevator_min_speed;
  // m/s typical (median) vertical speed: stairs-like
  double stairs_max_speed = shipped_detector::corroboration::stairs_max_speed;
  // m/s mean planar odometry speed: standing still
  double stationary_speed = shipped_detector::corroboration::stationary_speed;
  // m/s; faster is implausible on stairs or in a cabin
  double max_planar_speed = shipped_detector::corroboration::max_planar_speed;
  // mean similarity above: the walls moved along
  double static_scan_similarity = shipped_detector::corroboration::static_scan_similarity;
  // below: the surroundings changed
  double moving_scan_similarity = shipped_detector::corroboration::moving_scan_similarity;
  ScanSimilarityOptions scan;
};

// What the robot carries; the detector reads only these. Without a barometer the heights
// come from the IMU and the odometry (ImuHeight) and feed the same ride logic; a robot
// needs one of the two.
struct SensorOptions {
  bool barometer = shipped_detector::sensors::barometer;
  bool imu = shipped_detector::sensors::imu;
  bool odometry = shipped_detector::sensors::odometry;
  bool scan = shipped_detector::sensors::scan;
};

struct FloorDetectorOptions {
  SensorOptions sensors;
  BarometerOptions barometer;
  // The accelerometer's and the odometry's figures; its stationary_speed and
  // cabin_min_speed are the corroboration's stationary_speed and elevator_min_speed.
  ImuHeightOptions imu;
  TransitOptions transit;
  FloorIdentityOptions floors;
  CorroborationOptions corroboration;
};

// Reads the mapping holding barometer/transit/floors/corroboration; calls finish().
FloorDetectorOptions readFloorDetectorOptions(const common::ConfigNode& node);
// Reads the `detector` mapping of a component parameter file (config/floor_detector.yaml);
// the file's other keys belong to the component and are checked by it.
FloorDetectorOptions loadFloorDetectorOptions(const std::string& path);

}  // namespace storey::detection
