// Options of the floor detector, read strictly from YAML (config/floor_detector.yaml).
#pragma once

#include <string>
#include <vector>

#include "storey/common/config.h"
#include "storey/detection/imu_height.h"
#include "storey/detection/scan_similarity.h"

namespace storey::detection {

struct BarometerOptions {
  double temperature_kelvin = 288.15;           // air temperature for the hypsometric equation
  double temperature_uncertainty_kelvin = 5.0;  // scales the reported std-dev
  double min_pressure = 30000.0;                // Pa; readings outside are rejected
  double max_pressure = 110000.0;               // Pa
  double median_window = 1.0;    // s; Hampel window: spikes (door slams) shorter than half of it go
  double velocity_window = 6.0;  // s; least-squares slope of the filtered height
  double max_gap = 1.0;          // s; a longer silence restarts the filter
  double max_drift_rate = 100.0;  // Pa/h of weather drift assumed for the std-dev
};

struct TransitOptions {
  double start_velocity = 0.05;         // m/s; vertical speed that starts a candidate
  double end_velocity = 0.03;           // m/s; below it the robot is quiet
  double min_duration = 2.0;            // s; a candidate must last this long
  double min_start_change = 0.4;        // m; and have moved this far from the floor
  double settle_time = 3.0;             // s; quiet time to end a ride at a known floor
  double new_floor_settle_time = 15.0;  // s; quiet time to create a floor (or stay)
  double reference_window = 4.0;        // s; on-floor height averaged before a ride
};

struct FloorIdentityOptions {
  double storey_height = 3.0;         // m; nominal, for the minimum change
  double min_change_fraction = 0.65;  // of storey_height, to reach a new floor
  double match_tolerance = 1.0;       // m; arrival within this of a known floor resumes it
  std::vector<double> heights;        // building floor heights from config (may be empty)
  int initial_floor = 0;              // index into heights (ignored when empty)
};

struct CorroborationOptions {
  double elevator_min_speed = 0.3;      // m/s typical (median) vertical speed: elevator-like
  double stairs_max_speed = 0.2;        // m/s typical (median) vertical speed: stairs-like
  double stationary_speed = 0.05;       // m/s mean planar odometry speed: standing still
  double max_planar_speed = 1.0;        // m/s; faster is implausible on stairs or in a cabin
  double static_scan_similarity = 0.8;  // mean similarity above: the walls moved along
  double moving_scan_similarity = 0.5;  // below: the surroundings changed
  ScanSimilarityOptions scan;
};

// What the robot carries; the detector reads only these. Without a barometer the heights
// come from the IMU and the odometry (ImuHeight) and feed the same ride logic; a robot
// needs one of the two.
struct SensorOptions {
  bool barometer = true;
  bool imu = true;
  bool odometry = true;
  bool scan = true;
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
