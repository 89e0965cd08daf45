// The simulated building: floors with walls, doors and furniture, and the vertical shafts
// (elevators, stairwells) the floors share. Floor geometry is written in the floor's own
// frame; `Floor::frame` places that frame in the building frame (identity unless a
// scenario perturbs it). Shafts are written in the building frame: they are vertical.
#pragma once

#include <Eigen/Core>
#include <map>
#include <string>
#include <vector>

#include "storey/common/config.h"
#include "storey/geometry/pose2.h"

namespace storey::sim {

struct Segment {
  Eigen::Vector2d a = Eigen::Vector2d::Zero();
  Eigen::Vector2d b = Eigen::Vector2d::Zero();
  double length() const { return (b - a).norm(); }
};

// Where a definition came from, for error messages.
struct Origin {
  std::string file;
  int line = 0;
  std::string key;
  std::string describe() const;  // "file:line: key"
};

struct Wall {
  std::string id;                 // optional; lets a derived floor remove it
  std::vector<Segment> segments;  // a polyline or a closed rectangle
  Origin origin;
};

struct Door {
  std::string id;
  Segment span;  // the opening; must lie on a wall, which is cut there
  bool open = true;
  Origin origin;
};

struct Furniture {
  std::string id;
  Eigen::Vector2d center = Eigen::Vector2d::Zero();
  Eigen::Vector2d size = Eigen::Vector2d::Zero();  // along its own x and y
  double yaw = 0.0;
  Origin origin;
  std::vector<Segment> outline() const;
};

enum class ShaftKind { kElevator, kStairs };
enum class Side { kNorth, kSouth, kEast, kWest };  // +y, -y, +x, -x of the shaft

struct Shaft {
  std::string id;
  ShaftKind kind = ShaftKind::kElevator;
  Eigen::Vector2d center = Eigen::Vector2d::Zero();  // building frame
  Eigen::Vector2d size = Eigen::Vector2d::Zero();    // x and y extent
  Side door_side = Side::kSouth;
  double door_width = 1.0;
  std::vector<std::string> floors;  // floors it serves (all when not given)
  Origin origin;

  bool serves(const std::string& floor) const;
  // Outward unit normal of the door side.
  Eigen::Vector2d doorNormal() const;
  // Centre of the door opening on the shaft wall.
  Eigen::Vector2d doorCenter() const;
  Segment doorSpan() const;
  // The shaft's walls with the door left open (door leaf not included).
  std::vector<Segment> wallsWithGap() const;
  bool contains(const Eigen::Vector2d& p, double margin = 0.0) const;
};

struct Floor {
  std::string id;
  double height = 0.0;               // floor level above the building origin, metres
  geometry::Pose2 frame;             // floor frame in the building frame
  std::vector<Wall> walls;           // floor frame
  std::vector<Door> doors;           // floor frame
  std::vector<Furniture> furniture;  // floor frame
  Origin origin;
};

// A named straight distance the evaluator checks (e.g. a corridor's length).
struct Corridor {
  std::string name;
  std::string floor;
  Eigen::Vector2d from = Eigen::Vector2d::Zero();  // floor frame
  Eigen::Vector2d to = Eigen::Vector2d::Zero();
};

// The air: standard atmosphere at the building's altitude, and a slow weather drift.
struct Atmosphere {
  double sea_level_pressure = 101325.0;   // Pa
  double sea_level_temperature = 288.15;  // K
  double altitude = 0.0;                  // building origin above sea level, m
  double max_drift_hpa_per_hour = 0.5;    // |drift slope| is drawn up to this, per run
};

struct Building {
  std::string name;
  std::vector<Floor> floors;  // ordered by height
  std::vector<Shaft> shafts;
  std::vector<Corridor> corridors;
  Atmosphere atmosphere;
  // Random per-floor rotation about the first elevator (the paper's ten-floor test).
  double floor_rotation_sigma = 0.0;  // radians
  std::uint64_t floor_rotation_seed = 0;

  const Floor& floor(const std::string& id) const;  // throws std::invalid_argument
  int floorIndex(const std::string& id) const;      // -1 when unknown
  const Shaft& shaft(const std::string& id) const;  // throws std::invalid_argument
  int shaftIndex(const std::string& id) const;
};

// Reads the `building` mapping strictly and validates it (see docs/simulator.md).
// Errors are common::ConfigError naming file, key and line.
Building readBuilding(const common::ConfigNode& node);

// Absolute pressure (Pa) at `height` metres above the building origin, standard atmosphere.
double pressureAt(const Atmosphere& atmosphere, double height);

// Obstacle segments of one floor in the BUILDING frame: walls cut at doors, closed door
// leaves, furniture outlines, and the walls of the shafts serving the floor. Elevator
// landing doors are closed except for `open_landing` (a shaft id, "" for none).
std::vector<Segment> floorObstacles(const Building& building, int floor_index,
                                    const std::string& open_landing = "");
// The inside of a shaft with its door closed: what a robot in a moving cabin or on the
// stairs sees.
std::vector<Segment> closedShaft(const Shaft& shaft);

// Geometry helpers shared by validation and missions.
bool segmentsCross(const Segment& s, const Segment& t, double* at_s = nullptr);
double pointSegmentDistance(const Eigen::Vector2d& p, const Segment& s);
double segmentSegmentDistance(const Segment& s, const Segment& t);

}  // namespace storey::sim
