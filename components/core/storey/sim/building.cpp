#include "storey/sim/building.h"

#include <algorithm>
#include <cmath>
#include <set>
#include <sstream>
#include <stdexcept>

#include "storey/sim/random.h"

namespace storey::sim {
namespace {

constexpr double kMinSegmentLength = 0.05;  // metres; shorter is a typo, not a wall
constexpr double kOnWallTolerance = 0.03;   // a door this close to a wall line lies on it
constexpr double kPi = 3.14159265358979323846;

Origin originOf(const common::ConfigNode& node) { return {node.file(), node.line(), node.path()}; }

Eigen::Vector2d readPoint(const common::ConfigNode& node, const std::string& key) {
  const std::vector<double> v = node.getDoubles(key);
  if (v.size() != 2) node.fail(key, "expected a point [x, y]");
  return {v[0], v[1]};
}

std::vector<Eigen::Vector2d> readPoints(const common::ConfigNode& node, const std::string& key) {
  std::vector<Eigen::Vector2d> points;
  for (const auto& element : node.sequence(key)) {
    if (!element.isSequence() || element.yaml().size() != 2)
      node.fail(key, "expected a list of points [x, y]");
    // Read as config values: a coordinate that is not a finite number names its line.
    const double x =
        common::ConfigNode(element.yaml()[0], element.file(), element.path() + "[0]").as<double>();
    const double y =
        common::ConfigNode(element.yaml()[1], element.file(), element.path() + "[1]").as<double>();
    points.emplace_back(x, y);
  }
  return points;
}

std::vector<std::string> readStrings(const common::ConfigNode& node, const std::string& key) {
  std::vector<std::string> values;
  for (const auto& element : node.sequence(key)) values.push_back(element.as<std::string>());
  return values;
}

[[noreturn]] void failAt(const Origin& origin, const std::string& problem) {
  throw common::ConfigError(origin.file, origin.line, origin.key, problem);
}

void checkSegment(const common::ConfigNode& node, const std::string& key, const Segment& s) {
  if (s.length() < kMinSegmentLength) {
    std::ostringstream out;
    out << "degenerate segment from (" << s.a.x() << ", " << s.a.y() << ") to (" << s.b.x() << ", "
        << s.b.y() << "): shorter than " << kMinSegmentLength << " m";
    node.fail(key, out.str());
  }
}

Wall readWall(const common::ConfigNode& node) {
  Wall wall;
  wall.origin = originOf(node);
  wall.id = node.get<std::string>("id", "");
  const bool has_polyline = node.has("polyline");
  const bool has_rect = node.has("rect");
  if (has_polyline == has_rect) node.fail("", "a wall needs exactly one of 'polyline' or 'rect'");
  if (has_polyline) {
    const auto points = readPoints(node, "polyline");
    if (points.size() < 2) node.fail("polyline", "a polyline needs at least two points");
    for (std::size_t i = 0; i + 1 < points.size(); ++i) {
      wall.segments.push_back({points[i], points[i + 1]});
      checkSegment(node, "polyline", wall.segments.back());
    }
  } else {
    const auto corners = readPoints(node, "rect");
    if (corners.size() != 2) node.fail("rect", "expected [[xmin, ymin], [xmax, ymax]]");
    const Eigen::Vector2d lo = corners[0], hi = corners[1];
    if (hi.x() - lo.x() < kMinSegmentLength || hi.y() - lo.y() < kMinSegmentLength)
      node.fail("rect", "degenerate rectangle: max must exceed min by at least 0.05 m");
    const Eigen::Vector2d c1(hi.x(), lo.y()), c3(lo.x(), hi.y());
    wall.segments = {{lo, c1}, {c1, hi}, {hi, c3}, {c3, lo}};
  }
  node.finish();
  return wall;
}

Door readDoor(const common::ConfigNode& node) {
  Door door;
  door.origin = originOf(node);
  door.id = node.get<std::string>("id", "");
  const auto points = readPoints(node, "span");
  if (points.size() != 2) node.fail("span", "expected [[x, y], [x, y]]");
  door.span = {points[0], points[1]};
  checkSegment(node, "span", door.span);
  door.open = node.get<bool>("open");
  node.finish();
  return door;
}

Furniture readFurniture(const common::ConfigNode& node) {
  Furniture item;
  item.origin = originOf(node);
  item.id = node.get<std::string>("id", "");
  item.center = readPoint(node, "center");
  item.size = readPoint(node, "size");
  if (item.size.minCoeff() < kMinSegmentLength)
    node.fail("size", "furniture must be at least 0.05 m");
  item.yaw = node.getDouble("yaw_deg", 0.0, -360.0, 360.0) * kPi / 180.0;
  node.finish();
  return item;
}

Side readSide(const common::ConfigNode& node, const std::string& key) {
  const std::string side = node.getChoice(key, {"north", "south", "east", "west"});
  if (side == "north") return Side::kNorth;
  if (side == "south") return Side::kSouth;
  if (side == "east") return Side::kEast;
  return Side::kWest;
}

Shaft readShaft(const common::ConfigNode& node) {
  Shaft shaft;
  shaft.origin = originOf(node);
  shaft.id = node.get<std::string>("id");
  shaft.kind = node.getChoice("kind", {"elevator", "stairs"}) == "elevator" ? ShaftKind::kElevator
                                                                            : ShaftKind::kStairs;
  shaft.center = readPoint(node, "center");
  shaft.size = readPoint(node, "size");
  if (shaft.size.minCoeff() < 1.0) node.fail("size", "a shaft must be at least 1 m wide");
  shaft.door_side = readSide(node, "door_side");
  shaft.door_width = node.getDouble("door_width", 1.0, 0.6, 5.0);
  const double side_length = (shaft.door_side == Side::kNorth || shaft.door_side == Side::kSouth)
                                 ? shaft.size.x()
                                 : shaft.size.y();
  if (shaft.door_width > side_length - 0.1)
    node.fail("door_width", "the door is wider than the shaft side it is on");
  if (node.has("floors")) shaft.floors = readStrings(node, "floors");
  node.finish();
  return shaft;
}

// Parameters t in [0, 1] along `wall` covered by `door`, when the door lies on it.
bool doorInterval(const Segment& wall, const Segment& door, double* t0, double* t1) {
  const Eigen::Vector2d d = wall.b - wall.a;
  const double len2 = d.squaredNorm();
  const auto lineDistance = [&](const Eigen::Vector2d& p) {
    const Eigen::Vector2d r = p - wall.a;
    return std::abs(d.x() * r.y() - d.y() * r.x()) / std::sqrt(len2);
  };
  if (lineDistance(door.a) > kOnWallTolerance || lineDistance(door.b) > kOnWallTolerance)
    return false;
  double u0 = (door.a - wall.a).dot(d) / len2;
  double u1 = (door.b - wall.a).dot(d) / len2;
  if (u0 > u1) std::swap(u0, u1);
  const double tol = kOnWallTolerance / std::sqrt(len2);
  if (u0 < -tol || u1 > 1.0 + tol) return false;
  *t0 = std::max(0.0, u0);
  *t1 = std::min(1.0, u1);
  return true;
}

// Walls of a floor in the floor frame, cut at every door on them.
std::vector<Segment> cutWalls(const Floor& floor) {
  std::vector<Segment> result;
  for (const auto& wall : floor.walls) {
    for (const auto& segment : wall.segments) {
      std::vector<std::pair<double, double>> cuts;
      for (const auto& door : floor.doors) {
        double t0, t1;
        if (doorInterval(segment, door.span, &t0, &t1)) cuts.emplace_back(t0, t1);
      }
      std::sort(cuts.begin(), cuts.end());
      double from = 0.0;
      const Eigen::Vector2d d = segment.b - segment.a;
      for (const auto& [t0, t1] : cuts) {
        if (t0 > from) result.push_back({segment.a + from * d, segment.a + t0 * d});
        from = std::max(from, t1);
      }
      if (from < 1.0) result.push_back({segment.a + from * d, segment.b});
    }
  }
  // Pieces shorter than a centimetre are what is left between touching doors.
  result.erase(std::remove_if(result.begin(), result.end(),
                              [](const Segment& s) { return s.length() < 0.01; }),
               result.end());
  return result;
}

Segment transformed(const geometry::Pose2& frame, const Segment& s) {
  return {frame.transformPoint(s.a), frame.transformPoint(s.b)};
}

void validateFloor(const Building& building, const Floor& floor) {
  const std::vector<Segment> walls = cutWalls(floor);
  for (const auto& door : floor.doors) {
    bool on_wall = false;
    for (const auto& wall : floor.walls)
      for (const auto& segment : wall.segments) {
        double t0, t1;
        if (doorInterval(segment, door.span, &t0, &t1)) on_wall = true;
      }
    if (!on_wall)
      failAt(door.origin,
             "door '" + door.id + "' on floor " + floor.id + " does not lie on a wall");
  }
  for (const auto& item : floor.furniture) {
    const geometry::Pose2 pose(item.center.x(), item.center.y(), item.yaw);
    const auto inside = [&](const Eigen::Vector2d& p) {
      const Eigen::Vector2d local = pose.inverseTransformPoint(p).cwiseAbs();
      return local.x() < item.size.x() / 2.0 - 1e-9 && local.y() < item.size.y() / 2.0 - 1e-9;
    };
    for (const auto& wall : walls) {
      bool overlaps = inside(wall.a) || inside(wall.b);
      for (const auto& edge : item.outline()) overlaps = overlaps || segmentsCross(edge, wall);
      if (overlaps)
        failAt(item.origin,
               "furniture '" + item.id + "' on floor " + floor.id + " overlaps a wall");
    }
  }
  for (std::size_t i = 0; i < floor.furniture.size(); ++i)
    for (std::size_t j = i + 1; j < floor.furniture.size(); ++j)
      for (const auto& e1 : floor.furniture[i].outline())
        for (const auto& e2 : floor.furniture[j].outline())
          if (segmentsCross(e1, e2))
            failAt(floor.furniture[j].origin, "furniture '" + floor.furniture[j].id +
                                                  "' overlaps furniture '" + floor.furniture[i].id +
                                                  "' on floor " + floor.id);
  for (const auto& shaft : building.shafts) {
    if (!shaft.serves(floor.id)) continue;
    for (const auto& wall : walls) {
      const Segment w = transformed(floor.frame, wall);
      // A wall may end at a shaft but must not run into it.
      bool inside = false;
      for (int k = 1; k < 20 && !inside; ++k)
        inside = shaft.contains(w.a + (w.b - w.a) * (k / 20.0), -0.1);
      if (inside)
        failAt(floor.origin, "a wall of floor " + floor.id + " runs into shaft '" + shaft.id + "'");
    }
    for (const auto& item : floor.furniture)
      for (const auto& edge : item.outline()) {
        const Segment e = transformed(floor.frame, edge);
        if (shaft.contains(e.a, 0.0) || shaft.contains(e.b, 0.0))
          failAt(item.origin, "furniture '" + item.id + "' stands inside shaft '" + shaft.id + "'");
      }
  }
}

}  // namespace

std::string Origin::describe() const {
  std::ostringstream out;
  out << file;
  if (line > 0) out << ":" << line;
  if (!key.empty()) out << ": " << key;
  return out.str();
}

std::vector<Segment> Furniture::outline() const {
  const geometry::Pose2 pose(center.x(), center.y(), yaw);
  const Eigen::Vector2d h = size / 2.0;
  const Eigen::Vector2d c[4] = {
      pose.transformPoint({-h.x(), -h.y()}), pose.transformPoint({h.x(), -h.y()}),
      pose.transformPoint({h.x(), h.y()}), pose.transformPoint({-h.x(), h.y()})};
  return {{c[0], c[1]}, {c[1], c[2]}, {c[2], c[3]}, {c[3], c[0]}};
}

bool Shaft::serves(const std::string& floor) const {
  return floors.empty() || std::find(floors.begin(), floors.end(), floor) != floors.end();
}

Eigen::Vector2d Shaft::doorNormal() const {
  switch (door_side) {
    case Side::kNorth:
      return {0.0, 1.0};
    case Side::kSouth:
      return {0.0, -1.0};
    case Side::kEast:
      return {1.0, 0.0};
    case Side::kWest:
      break;
  }
  return {-1.0, 0.0};
}

Eigen::Vector2d Shaft::doorCenter() const {
  const Eigen::Vector2d n = doorNormal();
  return center + Eigen::Vector2d(n.x() * size.x() / 2.0, n.y() * size.y() / 2.0);
}

Segment Shaft::doorSpan() const {
  const Eigen::Vector2d n = doorNormal();
  const Eigen::Vector2d along(-n.y(), n.x());
  const Eigen::Vector2d c = doorCenter();
  return {c - along * door_width / 2.0, c + along * door_width / 2.0};
}

std::vector<Segment> Shaft::wallsWithGap() const {
  const Eigen::Vector2d h = size / 2.0;
  const Eigen::Vector2d sw = center + Eigen::Vector2d(-h.x(), -h.y());
  const Eigen::Vector2d se = center + Eigen::Vector2d(h.x(), -h.y());
  const Eigen::Vector2d ne = center + Eigen::Vector2d(h.x(), h.y());
  const Eigen::Vector2d nw = center + Eigen::Vector2d(-h.x(), h.y());
  std::vector<Segment> sides = {{sw, se}, {se, ne}, {ne, nw}, {nw, sw}};
  const int door_index = door_side == Side::kSouth   ? 0
                         : door_side == Side::kEast  ? 1
                         : door_side == Side::kNorth ? 2
                                                     : 3;
  std::vector<Segment> result;
  for (int i = 0; i < 4; ++i) {
    if (i != door_index) {
      result.push_back(sides[i]);
      continue;
    }
    const Segment& s = sides[i];
    const Eigen::Vector2d dir = (s.b - s.a).normalized();
    const double half = (s.b - s.a).norm() / 2.0;
    const Eigen::Vector2d mid = (s.a + s.b) / 2.0;
    result.push_back({s.a, mid - dir * door_width / 2.0});
    result.push_back({mid + dir * door_width / 2.0, s.b});
    (void)half;
  }
  return result;
}

bool Shaft::contains(const Eigen::Vector2d& p, double margin) const {
  const Eigen::Vector2d d = (p - center).cwiseAbs();
  return d.x() <= size.x() / 2.0 + margin && d.y() <= size.y() / 2.0 + margin;
}

const Floor& Building::floor(const std::string& id) const {
  const int i = floorIndex(id);
  if (i < 0) throw std::invalid_argument("no floor '" + id + "' in building " + name);
  return floors[i];
}

int Building::floorIndex(const std::string& id) const {
  for (std::size_t i = 0; i < floors.size(); ++i)
    if (floors[i].id == id) return static_cast<int>(i);
  return -1;
}

const Shaft& Building::shaft(const std::string& id) const {
  const int i = shaftIndex(id);
  if (i < 0) throw std::invalid_argument("no shaft '" + id + "' in building " + name);
  return shafts[i];
}

int Building::shaftIndex(const std::string& id) const {
  for (std::size_t i = 0; i < shafts.size(); ++i)
    if (shafts[i].id == id) return static_cast<int>(i);
  return -1;
}

Building readBuilding(const common::ConfigNode& node) {
  Building building;
  building.name = node.get<std::string>("name");
  if (node.has("atmosphere")) {
    const auto air = node.child("atmosphere");
    building.atmosphere.sea_level_pressure =
        air.getDouble("sea_level_pressure", 101325.0, 80000.0, 120000.0);
    building.atmosphere.sea_level_temperature =
        air.getDouble("sea_level_temperature", 288.15, 200.0, 350.0);
    building.atmosphere.altitude = air.getDouble("altitude", 0.0, -500.0, 5000.0);
    building.atmosphere.max_drift_hpa_per_hour =
        air.getDouble("max_drift_hpa_per_hour", 0.5, 0.0, 5.0);
    air.finish();
  }
  if (node.has("floor_rotation")) {
    const auto rotation = node.child("floor_rotation");
    building.floor_rotation_sigma = rotation.getDouble("sigma_deg", 0.0, 30.0) * kPi / 180.0;
    building.floor_rotation_seed = rotation.get<std::uint64_t>("seed");
    rotation.finish();
  }

  if (node.has("shafts"))
    for (const auto& element : node.sequence("shafts")) {
      Shaft shaft = readShaft(element);
      if (building.shaftIndex(shaft.id) >= 0)
        element.fail("id", "duplicate shaft id '" + shaft.id + "'");
      building.shafts.push_back(std::move(shaft));
    }

  for (const auto& element : node.sequence("floors")) {
    Floor floor;
    floor.origin = originOf(element);
    floor.id = element.get<std::string>("id");
    if (building.floorIndex(floor.id) >= 0)
      element.fail("id", "duplicate floor id '" + floor.id + "'");
    floor.height = element.getDouble("height", -1000.0, 1000.0);
    if (!building.floors.empty() && floor.height <= building.floors.back().height + 1.0)
      element.fail("height", "floors must be listed bottom up, at least 1 m apart");
    if (element.has("frame")) {
      const std::vector<double> f = element.getDoubles("frame");
      if (f.size() != 3) element.fail("frame", "expected [x, y, theta_deg]");
      floor.frame = geometry::Pose2(f[0], f[1], f[2] * kPi / 180.0);
    }
    if (element.has("like")) {
      const std::string base = element.get<std::string>("like");
      const int i = building.floorIndex(base);
      if (i < 0) element.fail("like", "unknown (or later) floor '" + base + "'");
      floor.walls = building.floors[i].walls;
      floor.doors = building.floors[i].doors;
      floor.furniture = building.floors[i].furniture;
    }
    if (element.has("remove")) {
      for (const std::string& id : readStrings(element, "remove")) {
        const auto before = floor.walls.size() + floor.doors.size() + floor.furniture.size();
        const auto matches = [&](const auto& item) { return !id.empty() && item.id == id; };
        floor.walls.erase(std::remove_if(floor.walls.begin(), floor.walls.end(), matches),
                          floor.walls.end());
        floor.doors.erase(std::remove_if(floor.doors.begin(), floor.doors.end(), matches),
                          floor.doors.end());
        floor.furniture.erase(
            std::remove_if(floor.furniture.begin(), floor.furniture.end(), matches),
            floor.furniture.end());
        if (before == floor.walls.size() + floor.doors.size() + floor.furniture.size())
          element.fail("remove", "nothing with id '" + id + "' to remove");
      }
    }
    for (const char* key : {"open_doors", "close_doors"}) {
      if (!element.has(key)) continue;
      for (const std::string& id : readStrings(element, key)) {
        bool found = false;
        for (auto& door : floor.doors)
          if (door.id == id) {
            door.open = std::string(key) == "open_doors";
            found = true;
          }
        if (!found) element.fail(key, "no door with id '" + id + "'");
      }
    }
    if (element.has("walls"))
      for (const auto& w : element.sequence("walls")) floor.walls.push_back(readWall(w));
    if (element.has("doors"))
      for (const auto& d : element.sequence("doors")) floor.doors.push_back(readDoor(d));
    if (element.has("furniture"))
      for (const auto& f : element.sequence("furniture"))
        floor.furniture.push_back(readFurniture(f));
    std::set<std::string> ids;
    const auto checkId = [&](const std::string& id, const Origin& origin) {
      if (!id.empty() && !ids.insert(id).second)
        failAt(origin, "duplicate id '" + id + "' on floor " + floor.id);
    };
    for (const auto& w : floor.walls) checkId(w.id, w.origin);
    for (const auto& d : floor.doors) checkId(d.id, d.origin);
    for (const auto& f : floor.furniture) checkId(f.id, f.origin);
    element.finish();
    building.floors.push_back(std::move(floor));
  }
  if (building.floors.empty()) node.fail("floors", "a building needs at least one floor");

  if (node.has("corridors"))
    for (const auto& element : node.sequence("corridors")) {
      Corridor corridor;
      corridor.name = element.get<std::string>("name");
      corridor.floor = element.get<std::string>("floor");
      if (building.floorIndex(corridor.floor) < 0)
        element.fail("floor", "unknown floor '" + corridor.floor + "'");
      corridor.from = readPoint(element, "from");
      corridor.to = readPoint(element, "to");
      element.finish();
      building.corridors.push_back(corridor);
    }
  node.finish();

  // Shafts: known floors, no overlap, elevators serve at least two floors.
  for (auto& shaft : building.shafts) {
    for (const auto& id : shaft.floors)
      if (building.floorIndex(id) < 0)
        failAt(shaft.origin, "shaft '" + shaft.id + "' lists unknown floor '" + id + "'");
    int served = 0;
    for (const auto& floor : building.floors) served += shaft.serves(floor.id) ? 1 : 0;
    if (served < 2) failAt(shaft.origin, "shaft '" + shaft.id + "' serves fewer than two floors");
  }
  // A floor no shaft reaches cannot be part of the building's one connected whole.
  if (building.floors.size() > 1)
    for (const auto& floor : building.floors) {
      bool reached = false;
      for (const auto& shaft : building.shafts) reached = reached || shaft.serves(floor.id);
      if (!reached)
        failAt(floor.origin, "floor " + floor.id + " is served by no elevator or stairwell");
    }
  for (std::size_t i = 0; i < building.shafts.size(); ++i)
    for (std::size_t j = i + 1; j < building.shafts.size(); ++j) {
      const Shaft& a = building.shafts[i];
      const Shaft& b = building.shafts[j];
      const Eigen::Vector2d d = (a.center - b.center).cwiseAbs();
      if (d.x() < (a.size.x() + b.size.x()) / 2.0 && d.y() < (a.size.y() + b.size.y()) / 2.0)
        failAt(b.origin, "shaft '" + b.id + "' overlaps shaft '" + a.id + "'");
    }

  // The ten-floor test: every floor above the first turned about the first elevator.
  if (building.floor_rotation_sigma > 0.0) {
    Eigen::Vector2d pivot = Eigen::Vector2d::Zero();
    for (const auto& shaft : building.shafts)
      if (shaft.kind == ShaftKind::kElevator) {
        pivot = shaft.center;
        break;
      }
    Rng rng(building.floor_rotation_seed);
    for (std::size_t i = 1; i < building.floors.size(); ++i) {
      const double angle = rng.gaussian() * building.floor_rotation_sigma;
      const geometry::Pose2 turn = geometry::Pose2(pivot.x(), pivot.y(), angle) *
                                   geometry::Pose2(-pivot.x(), -pivot.y(), 0.0);
      building.floors[i].frame = turn * building.floors[i].frame;
    }
  }
  for (const auto& floor : building.floors) validateFloor(building, floor);
  return building;
}

double pressureAt(const Atmosphere& atmosphere, double height) {
  // International standard atmosphere, troposphere: p = p0 (1 - L h / T0)^(g M / (R L)).
  constexpr double kLapseRate = 0.0065;  // K/m
  constexpr double kExponent = 9.80665 * 0.0289644 / (8.31446 * kLapseRate);
  const double h = atmosphere.altitude + height;
  return atmosphere.sea_level_pressure *
         std::pow(1.0 - kLapseRate * h / atmosphere.sea_level_temperature, kExponent);
}

std::vector<Segment> floorObstacles(const Building& building, int floor_index,
                                    const std::string& open_landing) {
  const Floor& floor = building.floors.at(floor_index);
  std::vector<Segment> result;
  for (const auto& s : cutWalls(floor)) result.push_back(transformed(floor.frame, s));
  for (const auto& door : floor.doors)
    if (!door.open) result.push_back(transformed(floor.frame, door.span));
  for (const auto& item : floor.furniture)
    for (const auto& s : item.outline()) result.push_back(transformed(floor.frame, s));
  for (const auto& shaft : building.shafts) {
    if (!shaft.serves(floor.id)) continue;
    for (const auto& s : shaft.wallsWithGap()) result.push_back(s);
    // Elevator landing doors stay shut unless the cabin waits here with its door open.
    if (shaft.kind == ShaftKind::kElevator && shaft.id != open_landing)
      result.push_back(shaft.doorSpan());
  }
  return result;
}

std::vector<Segment> closedShaft(const Shaft& shaft) {
  std::vector<Segment> result = shaft.wallsWithGap();
  result.push_back(shaft.doorSpan());
  return result;
}

bool segmentsCross(const Segment& s, const Segment& t, double* at_s) {
  const Eigen::Vector2d r = s.b - s.a;
  const Eigen::Vector2d q = t.b - t.a;
  const double denom = r.x() * q.y() - r.y() * q.x();
  if (std::abs(denom) < 1e-12) return false;  // parallel: touching is not crossing
  const Eigen::Vector2d w = t.a - s.a;
  const double u = (w.x() * q.y() - w.y() * q.x()) / denom;
  const double v = (w.x() * r.y() - w.y() * r.x()) / denom;
  constexpr double kEps = 1e-9;
  if (u <= kEps || u >= 1.0 - kEps || v <= kEps || v >= 1.0 - kEps) return false;
  if (at_s) *at_s = u;
  return true;
}

double pointSegmentDistance(const Eigen::Vector2d& p, const Segment& s) {
  const Eigen::Vector2d d = s.b - s.a;
  const double len2 = d.squaredNorm();
  const double t = len2 > 0.0 ? std::clamp((p - s.a).dot(d) / len2, 0.0, 1.0) : 0.0;
  return (s.a + t * d - p).norm();
}

double segmentSegmentDistance(const Segment& s, const Segment& t) {
  if (segmentsCross(s, t)) return 0.0;
  return std::min({pointSegmentDistance(s.a, t), pointSegmentDistance(s.b, t),
                   pointSegmentDistance(t.a, s), pointSegmentDistance(t.b, s)});
}

}  // namespace storey::sim
