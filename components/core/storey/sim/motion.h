// A robot's true motion as a sequence of analytic pieces (wait, turn on the spot, drive
// straight, lift), each with a trapezoidal velocity profile, so pose, velocity and
// acceleration are exact at any time. Planning a mission checks it against the geometry.
#pragma once

#include <string>
#include <vector>

#include "storey/geometry/pose2.h"
#include "storey/sim/building.h"
#include "storey/sim/scenario.h"

namespace storey::sim {

// What the laser sees: a floor (optionally with one elevator's landing door open) or the
// inside of a shaft with its door shut (a moving cabin, a stairwell).
struct SceneKey {
  enum class Kind { kFloor, kInsideShaft };
  Kind kind = Kind::kFloor;
  int floor = 0;           // kFloor
  std::string open_shaft;  // kFloor: elevator whose landing door is open ("" none)
  int shaft = -1;          // kInsideShaft
  bool operator==(const SceneKey& o) const {
    return kind == o.kind && floor == o.floor && open_shaft == o.open_shaft && shaft == o.shaft;
  }
};

std::vector<Segment> sceneObstacles(const Building& building, const SceneKey& key);

// Trapezoidal profile over a distance: accelerate, cruise, brake.
struct Profile {
  double distance = 0.0, peak = 0.0, accel = 0.0, t_accel = 0.0, t_cruise = 0.0;
  static Profile make(double distance, double max_speed, double accel);
  double duration() const { return 2.0 * t_accel + t_cruise; }
  // Position, speed and acceleration along the profile at time t in [0, duration].
  void at(double t, double* s, double* v, double* a) const;
};

struct MotionState {
  geometry::Pose2 pose;  // building frame
  double z = 0.0;        // height above the building origin
  double v = 0.0;        // forward speed
  double omega = 0.0;    // yaw rate
  double a = 0.0;        // forward acceleration
  double vz = 0.0, az = 0.0;
  double pitch = 0.0;      // nose up on a slope (stairs, a ramp), rad
  double travelled = 0.0;  // m driven along the current straight piece (horizontal)
  int floor = 0;  // floor index the robot counts as on
  int scene = 0;  // index into Trajectory::scenes
};

struct Transit {
  std::string robot;
  double start = 0.0, end = 0.0;
  int from_floor = 0, to_floor = 0;
  std::string mode;                     // "elevator" or "stairs"
  double odometry_heading_error = 0.0;  // rad added to the odometry heading by this ride
};

class Trajectory {
 public:
  struct Piece {
    enum class Kind { kWait, kRotate, kTranslate, kLift };
    Kind kind = Kind::kWait;
    double t0 = 0.0;
    geometry::Pose2 start;
    double z0 = 0.0;
    double sign = 1.0;     // direction of a turn or lift
    double dz = 0.0;       // height change while translating (stairs)
    double seconds = 0.0;  // kWait
    Profile profile;
    int floor = 0, scene = 0;
    double duration() const { return kind == Kind::kWait ? seconds : profile.duration(); }
  };

  double startTime() const { return pieces_.empty() ? 0.0 : pieces_.front().t0; }
  double endTime() const;
  MotionState at(double t) const;  // clamped to [startTime, endTime]
  const std::vector<Piece>& pieces() const { return pieces_; }
  const std::vector<SceneKey>& scenes() const { return scenes_; }
  const std::vector<Transit>& transits() const { return transits_; }
  // Times at which an elevator ride ends (odometry heading error is injected there).
  const std::vector<double>& rideEnds() const { return ride_ends_; }
  // Times at which an elevator door finished opening or closing (a jolt in the IMU).
  const std::vector<double>& doorMoves() const { return door_moves_; }

 private:
  friend class MissionPlanner;
  std::vector<Piece> pieces_;
  std::vector<SceneKey> scenes_;
  std::vector<Transit> transits_;
  std::vector<double> ride_ends_;
  std::vector<double> door_moves_;
};

// Turns a robot's mission into a trajectory, validating every leg: a waypoint inside or
// too close to an obstacle, a path crossing a wall, a ride to a floor the shaft does not
// reach... throw common::ConfigError at the mission step at fault.
Trajectory planMission(const Building& building, const RobotSpec& robot);

}  // namespace storey::sim
