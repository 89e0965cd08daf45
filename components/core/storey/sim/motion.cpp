#include "storey/sim/motion.h"

#include <algorithm>
#include <cmath>
#include <sstream>

namespace storey::sim {
namespace {


std::string point(const Eigen::Vector2d& p) {
  std::ostringstream out;
  out.precision(3);
  out << "(" << p.x() << ", " << p.y() << ")";
  return out.str();
}

}  // namespace

std::vector<Segment> sceneObstacles(const Building& building, const SceneKey& key) {
  if (key.kind == SceneKey::Kind::kInsideShaft) return closedShaft(building.shafts.at(key.shaft));
  return floorObstacles(building, key.floor, key.open_shaft);
}

Profile Profile::make(double distance, double max_speed, double accel) {
  Profile p;
  p.distance = std::abs(distance);
  p.accel = accel;
  if (p.distance <= 0.0) return p;
  const double t_full = max_speed / accel;
  if (p.distance < max_speed * t_full) {  // never reaches cruise speed: a triangle
    p.t_accel = std::sqrt(p.distance / accel);
    p.peak = accel * p.t_accel;
    p.t_cruise = 0.0;
  } else {
    p.t_accel = t_full;
    p.peak = max_speed;
    p.t_cruise = (p.distance - max_speed * t_full) / max_speed;
  }
  return p;
}

void Profile::at(double t, double* s, double* v, double* a) const {
  const double total = duration();
  t = std::clamp(t, 0.0, total);
  if (distance <= 0.0) {
    *s = *v = *a = 0.0;
  } else if (t < t_accel) {
    *s = 0.5 * accel * t * t;
    *v = accel * t;
    *a = accel;
  } else if (t <= t_accel + t_cruise) {
    *s = 0.5 * accel * t_accel * t_accel + peak * (t - t_accel);
    *v = peak;
    *a = 0.0;
  } else {
    const double left = total - t;
    *s = distance - 0.5 * accel * left * left;
    *v = accel * left;
    *a = left > 0.0 ? -accel : 0.0;
  }
}

double Trajectory::endTime() const {
  return pieces_.empty() ? 0.0 : pieces_.back().t0 + pieces_.back().duration();
}

MotionState Trajectory::at(double t) const {
  MotionState state;
  if (pieces_.empty()) return state;
  t = std::clamp(t, startTime(), endTime());
  // The last piece starting at or before t.
  auto it = std::upper_bound(pieces_.begin(), pieces_.end(), t,
                             [](double time, const Piece& p) { return time < p.t0; });
  const Piece& p = *(it == pieces_.begin() ? it : std::prev(it));
  state.floor = p.floor;
  state.scene = p.scene;
  state.pose = p.start;
  state.z = p.z0;
  double s = 0.0, v = 0.0, a = 0.0;
  if (p.kind != Piece::Kind::kWait) p.profile.at(t - p.t0, &s, &v, &a);
  switch (p.kind) {
    case Piece::Kind::kWait:
      break;
    case Piece::Kind::kRotate:
      state.pose = geometry::Pose2(p.start.x(), p.start.y(), p.start.theta() + p.sign * s);
      state.omega = p.sign * v;
      break;
    case Piece::Kind::kTranslate: {
      const double c = std::cos(p.start.theta()), sn = std::sin(p.start.theta());
      state.pose = geometry::Pose2(p.start.x() + c * s, p.start.y() + sn * s, p.start.theta());
      state.v = v;
      state.a = a;
      const double slope = p.profile.distance > 0.0 ? p.dz / p.profile.distance : 0.0;
      state.z = p.z0 + slope * s;
      state.vz = slope * v;
      state.az = slope * a;
      state.pitch = std::atan(slope);
      state.travelled = s;
      break;
    }
    case Piece::Kind::kLift:
      state.z = p.z0 + p.sign * s;
      state.vz = p.sign * v;
      state.az = p.sign * a;
      break;
  }
  return state;
}

class MissionPlanner {
 public:
  MissionPlanner(const Building& building, const RobotSpec& robot)
      : building_(building), robot_(robot), motion_(robot.model.motion) {}

  Trajectory plan() {
    floor_ = building_.floorIndex(robot_.start_floor);
    if (floor_ < 0)
      failAt(robot_.origin, "start floor '" + robot_.start_floor + "' is not in the building");
    const Floor& floor = building_.floors[floor_];
    pose_ = floor.frame * robot_.start_pose;
    z_ = floor.height;
    t_ = robot_.start_time;
    current_origin_ = robot_.origin;
    checkPosition(floorScene(""), pose_.translation(), "the start pose");
    for (const auto& step : robot_.mission) {
      current_origin_ = step.origin;
      switch (step.kind) {
        case MissionStep::Kind::kGo:
          driveTo(building_.floors[floor_].frame.transformPoint(step.target), floorScene(""),
                  motion_.speed, step.rise);
          break;
        case MissionStep::Kind::kWait:
          wait(step.seconds, floorScene(""));
          break;
        case MissionStep::Kind::kElevator:
          ride(step);
          break;
        case MissionStep::Kind::kStairs:
          climb(step);
          break;
      }
    }
    if (trajectory_.pieces_.empty()) wait(1.0, floorScene(""));
    return std::move(trajectory_);
  }

 private:
  [[noreturn]] void failAt(const Origin& origin, const std::string& problem) const {
    throw common::ConfigError(origin.file, origin.line, origin.key,
                              "robot '" + robot_.name + "': " + problem);
  }
  [[noreturn]] void fail(const std::string& problem) const { failAt(current_origin_, problem); }

  int sceneIndex(const SceneKey& key) {
    for (std::size_t i = 0; i < trajectory_.scenes_.size(); ++i)
      if (trajectory_.scenes_[i] == key) return static_cast<int>(i);
    trajectory_.scenes_.push_back(key);
    obstacles_.push_back(sceneObstacles(building_, key));
    return static_cast<int>(trajectory_.scenes_.size() - 1);
  }
  int floorScene(const std::string& open_shaft) {
    SceneKey key;
    key.floor = floor_;
    key.open_shaft = open_shaft;
    return sceneIndex(key);
  }
  int shaftScene(int shaft) {
    SceneKey key;
    key.kind = SceneKey::Kind::kInsideShaft;
    key.shaft = shaft;
    return sceneIndex(key);
  }
  std::string sceneName(int scene) const {
    const SceneKey& key = trajectory_.scenes_[scene];
    if (key.kind == SceneKey::Kind::kInsideShaft) return "shaft " + building_.shafts[key.shaft].id;
    return "floor " + building_.floors[key.floor].id;
  }

  void checkPosition(int scene, const Eigen::Vector2d& p, const std::string& what) const {
    for (const auto& s : obstacles_[scene])
      if (pointSegmentDistance(p, s) < motion_.radius) {
        const Eigen::Vector2d local = building_.floors[floor_].frame.inverseTransformPoint(p);
        fail(what + " " + point(local) + " on " + sceneName(scene) +
             " is inside or closer than the robot radius to a wall or obstacle");
      }
  }
  void checkPath(int scene, const Eigen::Vector2d& from, const Eigen::Vector2d& to) const {
    const Segment path{from, to};
    for (const auto& s : obstacles_[scene])
      if (segmentSegmentDistance(path, s) < motion_.radius) {
        const geometry::Pose2& frame = building_.floors[floor_].frame;
        fail("the path from " + point(frame.inverseTransformPoint(from)) + " to " +
             point(frame.inverseTransformPoint(to)) + " on " + sceneName(scene) +
             " crosses or grazes a wall or obstacle near " +
             point(frame.inverseTransformPoint(s.a)) + "-" +
             point(frame.inverseTransformPoint(s.b)));
      }
  }

  Trajectory::Piece newPiece(Trajectory::Piece::Kind kind, int scene) const {
    Trajectory::Piece piece;
    piece.kind = kind;
    piece.t0 = t_;
    piece.start = pose_;
    piece.z0 = z_;
    piece.floor = floor_;
    piece.scene = scene;
    return piece;
  }
  void push(const Trajectory::Piece& piece) {
    trajectory_.pieces_.push_back(piece);
    t_ += piece.duration();
  }

  void wait(double seconds, int scene) {
    if (seconds <= 0.0) return;
    auto piece = newPiece(Trajectory::Piece::Kind::kWait, scene);
    piece.seconds = seconds;
    push(piece);
  }
  void turnTo(double heading, int scene) {
    const double delta = geometry::angleDiff(heading, pose_.theta());
    if (std::abs(delta) < 1e-9) return;
    auto piece = newPiece(Trajectory::Piece::Kind::kRotate, scene);
    piece.sign = delta > 0 ? 1.0 : -1.0;
    piece.profile = Profile::make(delta, motion_.turn_rate, motion_.angular_acceleration);
    push(piece);
    pose_ = geometry::Pose2(pose_.x(), pose_.y(), heading);
  }
  // Turn towards `target`, then drive straight to it (climbing `dz` on the way).
  void driveTo(const Eigen::Vector2d& target, int scene, double speed, double dz = 0.0) {
    checkPosition(scene, target, "the waypoint");
    checkPath(scene, pose_.translation(), target);
    const Eigen::Vector2d d = target - pose_.translation();
    const double distance = d.norm();
    if (distance < 1e-6) return;
    turnTo(std::atan2(d.y(), d.x()), scene);
    auto piece = newPiece(Trajectory::Piece::Kind::kTranslate, scene);
    piece.profile = Profile::make(distance, speed, motion_.acceleration);
    piece.dz = dz;
    push(piece);
    pose_ = geometry::Pose2(target.x(), target.y(), pose_.theta());
    z_ += dz;
  }

  int checkedShaft(const MissionStep& step, ShaftKind kind, int* to_floor) const {
    const int shaft = building_.shaftIndex(step.shaft);
    if (shaft < 0) fail("there is no shaft '" + step.shaft + "'");
    const Shaft& s = building_.shafts[shaft];
    const char* wanted = kind == ShaftKind::kElevator ? "an elevator" : "a stairwell";
    if (s.kind != kind) fail("shaft '" + s.id + "' is not " + wanted);
    *to_floor = building_.floorIndex(step.to_floor);
    if (*to_floor < 0) fail("there is no floor '" + step.to_floor + "'");
    if (*to_floor == floor_) fail("the robot is already on floor " + step.to_floor);
    const std::string here = building_.floors[floor_].id;
    if (!s.serves(here))
      fail("shaft '" + s.id + "' does not reach floor " + here + " (robot is there)");
    if (!s.serves(step.to_floor))
      fail("shaft '" + s.id + "' does not reach floor " + step.to_floor);
    return shaft;
  }

  Eigen::Vector2d landing(const Shaft& shaft) const {
    return shaft.doorCenter() + shaft.doorNormal() * (motion_.radius + 0.6);
  }

  void ride(const MissionStep& step) {
    int to_floor = 0;
    const int index = checkedShaft(step, ShaftKind::kElevator, &to_floor);
    const Shaft& shaft = building_.shafts[index];
    if (shaft.door_width < 2.0 * motion_.radius + 0.1)
      fail("the door of elevator '" + shaft.id + "' is too narrow for the robot");
    const Eigen::Vector2d outside = landing(shaft);
    const Eigen::Vector2d n = shaft.doorNormal();
    const double facing_in = std::atan2(-n.y(), -n.x());
    driveTo(outside, floorScene(""), motion_.speed);
    turnTo(facing_in, floorScene(""));
    const int open_here = floorScene(shaft.id);
    wait(motion_.door_time, open_here);  // landing door opens
    trajectory_.door_moves_.push_back(t_);
    driveTo(shaft.center, open_here, motion_.speed);
    wait(motion_.door_time, open_here);  // door closes behind the robot
    trajectory_.door_moves_.push_back(t_);
    const int cabin = shaftScene(index);
    Transit transit{robot_.name, t_, 0.0, floor_, to_floor, "elevator"};
    const double dz = building_.floors[to_floor].height - building_.floors[floor_].height;
    auto lift = newPiece(Trajectory::Piece::Kind::kLift, cabin);
    lift.sign = dz > 0 ? 1.0 : -1.0;
    lift.profile = Profile::make(dz, motion_.elevator_speed, motion_.elevator_acceleration);
    push(lift);
    z_ += dz;
    floor_ = to_floor;
    transit.end = t_;
    trajectory_.transits_.push_back(transit);
    trajectory_.ride_ends_.push_back(t_);
    turnTo(std::atan2(n.y(), n.x()), cabin);
    const int open_there = floorScene(shaft.id);
    wait(motion_.door_time, open_there);  // doors open on the new floor
    trajectory_.door_moves_.push_back(t_);
    driveTo(outside, open_there, motion_.speed);
  }

  void climb(const MissionStep& step) {
    int to_floor = 0;
    const int index = checkedShaft(step, ShaftKind::kStairs, &to_floor);
    const Shaft& shaft = building_.shafts[index];
    const Eigen::Vector2d n = shaft.doorNormal();
    const Eigen::Vector2d across(-n.y(), n.x());
    const double depth = std::abs(n.x()) > 0.5 ? shaft.size.x() : shaft.size.y();
    const double width = std::abs(n.x()) > 0.5 ? shaft.size.y() : shaft.size.x();
    if (width < 4.0 * motion_.radius + 0.2 || depth < 2.0 * motion_.radius + 1.5)
      fail("stairwell '" + shaft.id + "' is too small for two flights and the robot");
    // Two flights side by side: up one half of the well, turn on the half-landing, up the
    // other half back towards the door.
    const double margin = motion_.radius + 0.15;
    const Eigen::Vector2d inside = shaft.doorCenter() - n * margin;
    const Eigen::Vector2d far_end = shaft.doorCenter() - n * (depth - margin);
    const Eigen::Vector2d left = across * (width / 4.0);
    driveTo(landing(shaft), floorScene(""), motion_.speed);
    driveTo(inside, floorScene(""), motion_.speed);
    const int well = shaftScene(index);
    const double dz = building_.floors[to_floor].height - building_.floors[floor_].height;
    driveTo(inside + left, well, motion_.stairs_speed);
    Transit transit{robot_.name, t_, 0.0, floor_, to_floor, "stairs"};
    driveTo(far_end + left, well, motion_.stairs_speed, dz / 2.0);
    driveTo(far_end - left, well, motion_.stairs_speed);
    driveTo(inside - left, well, motion_.stairs_speed, dz / 2.0);
    floor_ = to_floor;
    transit.end = t_;
    trajectory_.transits_.push_back(transit);
    driveTo(inside, well, motion_.stairs_speed);
    driveTo(landing(shaft), floorScene(""), motion_.speed);
  }

  const Building& building_;
  const RobotSpec& robot_;
  const MotionOptions& motion_;
  Trajectory trajectory_;
  std::vector<std::vector<Segment>> obstacles_;  // per scene, for validation
  geometry::Pose2 pose_;
  double z_ = 0.0;
  double t_ = 0.0;
  int floor_ = 0;
  Origin current_origin_;
};

Trajectory planMission(const Building& building, const RobotSpec& robot) {
  return MissionPlanner(building, robot).plan();
}

}  // namespace storey::sim
