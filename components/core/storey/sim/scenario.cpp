#include "storey/sim/scenario.h"

#include <filesystem>

#include "storey/sim/motion.h"

namespace storey::sim {
namespace {

constexpr double kDegree = 3.14159265358979323846 / 180.0;

geometry::Pose2 readPose(const common::ConfigNode& node, const std::string& key) {
  const std::vector<double> v = node.getDoubles(key);
  if (v.size() != 3) node.fail(key, "expected [x, y, theta_deg]");
  return geometry::Pose2(v[0], v[1], v[2] * kDegree);
}

MissionStep readStep(const common::ConfigNode& node) {
  MissionStep step;
  step.origin = {node.file(), node.line(), node.path()};
  int kinds = 0;
  if (node.has("go")) {
    ++kinds;
    step.kind = MissionStep::Kind::kGo;
    const std::vector<double> v = node.getDoubles("go");
    if (v.size() != 2) node.fail("go", "expected a waypoint [x, y]");
    step.target = {v[0], v[1]};
    if (node.has("rise")) step.rise = node.getDouble("rise", -2.0, 2.0);
  }
  if (node.has("wait")) {
    ++kinds;
    step.kind = MissionStep::Kind::kWait;
    step.seconds = node.getDouble("wait", 0.0, 3600.0);
  }
  for (const char* key : {"elevator", "stairs"}) {
    if (!node.has(key)) continue;
    ++kinds;
    step.kind =
        std::string(key) == "elevator" ? MissionStep::Kind::kElevator : MissionStep::Kind::kStairs;
    step.shaft = node.get<std::string>(key);
    step.to_floor = node.get<std::string>("to");
  }
  if (kinds != 1)
    node.fail("", "a mission step needs exactly one of 'go', 'wait', 'elevator' or 'stairs'");
  node.finish();
  return step;
}

Scenario readScenario(const common::ConfigNode& root, const std::string& robots_dir,
                      const std::string& dir) {
  Scenario scenario;
  if (root.has("building_file")) {
    // Another scenario's building, e.g. a fleet in an existing building.
    const std::string file = root.get<std::string>("building_file");
    if (root.has("building")) root.fail("building", "give either 'building' or 'building_file'");
    const std::string path = (std::filesystem::path(dir) / file).lexically_normal().string();
    if (dir.empty() || !std::filesystem::exists(path))
      root.fail("building_file", "no building file " + path);
    scenario.building = readBuilding(common::ConfigNode::loadFile(path).child("building"));
  } else {
    scenario.building = readBuilding(root.child("building"));
  }
  scenario.name = root.get<std::string>("name", scenario.building.name);
  for (const auto& element : root.sequence("robots")) {
    RobotSpec robot;
    robot.origin = {element.file(), element.line(), element.path()};
    robot.name = element.get<std::string>("name");
    for (const auto& other : scenario.robots)
      if (other.name == robot.name)
        element.fail("name", "duplicate robot name '" + robot.name + "'");
    if (robot.name.empty() || robot.name.find_first_of("/ \t") != std::string::npos)
      element.fail("name",
                   "a robot name must be non-empty, without '/' or spaces (it names topics)");
    if (element.has("model") && element.yaml()["model"].IsMap()) {
      robot.model = readRobotModel(element.child("model"));
      robot.model.name = robot.name + "-inline";
    } else {
      const std::string model = element.get<std::string>("model");
      if (robots_dir.empty())
        element.fail("model", "robot model '" + model + "' must be given inline here");
      const std::string path = (std::filesystem::path(robots_dir) / (model + ".yaml")).string();
      if (!std::filesystem::exists(path)) element.fail("model", "no robot model file " + path);
      robot.model = readRobotModel(common::ConfigNode::loadFile(path));
      robot.model.name = model;
    }
    const auto start = element.child("start");
    robot.start_floor = start.get<std::string>("floor");
    if (scenario.building.floorIndex(robot.start_floor) < 0)
      start.fail("floor", "unknown floor '" + robot.start_floor + "'");
    robot.start_pose = readPose(start, "pose");
    robot.start_time = start.getDouble("time", 0.0, 0.0, 86400.0);
    start.finish();
    for (const auto& step : element.sequence("mission")) robot.mission.push_back(readStep(step));
    element.finish();
    scenario.robots.push_back(std::move(robot));
  }
  if (scenario.robots.empty()) root.fail("robots", "a scenario needs at least one robot");
  root.finish();
  // Planning validates every mission against the geometry.
  for (const auto& robot : scenario.robots) planMission(scenario.building, robot);
  return scenario;
}

}  // namespace

RobotModel readRobotModel(const common::ConfigNode& node) {
  RobotModel model;
  {
    const auto n = node.child("laser");
    LaserOptions& o = model.laser;
    o.rate = n.getDouble("rate", 0.1, 100.0);
    o.fov = n.getDouble("fov_deg", 1.0, 360.0) * kDegree;
    o.beams = n.getInt("beams", 2, 10000);
    o.min_range = n.getDouble("min_range", 0.0, 0.0, 10.0);
    o.max_range = n.getDouble("max_range", 0.5, 500.0);
    if (o.max_range <= o.min_range) n.fail("max_range", "must exceed min_range");
    o.range_sigma = n.getDouble("range_sigma", 0.0, 1.0);
    o.dropout = n.getDouble("dropout", 0.0, 0.0, 1.0);
    if (n.has("offset")) o.offset = readPose(n, "offset");
    n.finish();
  }
  {
    const auto n = node.child("odometry");
    OdometryOptions& o = model.odometry;
    o.rate = n.getDouble("rate", 0.1, 1000.0);
    o.translation_sigma = n.getDouble("translation_sigma", 0.0, 1.0);
    o.rotation_sigma = n.getDouble("rotation_sigma", 0.0, 1.0);
    o.rotation_per_metre_sigma = n.getDouble("rotation_per_metre_sigma", 0.0, 1.0);
    o.elevator_heading_sigma = n.getDouble("elevator_heading_sigma_deg", 0.0, 0.0, 45.0) * kDegree;
    o.stall_interval = n.getDouble("stall_interval", 0.0, 0.0, 1e6);
    o.stall_duration = n.getDouble("stall_duration", o.stall_duration, 0.0, 60.0);
    n.finish();
  }
  {
    // A robot without a barometer has no `barometer` section.
    model.barometer.present = node.has("barometer");
    if (model.barometer.present) {
      const auto n = node.child("barometer");
      model.barometer.rate = n.getDouble("rate", 0.1, 1000.0);
      model.barometer.sigma = n.getDouble("sigma", 0.0, 1000.0);
      n.finish();
    }
  }
  {
    const auto n = node.child("imu");
    model.imu.rate = n.getDouble("rate", 0.1, 2000.0);
    model.imu.accel_sigma = n.getDouble("accel_sigma", 0.0, 10.0);
    model.imu.gyro_sigma = n.getDouble("gyro_sigma", 0.0, 10.0);
    // Optional: without them the accelerometer has no bias and stairs do not shake it.
    model.imu.accel_bias_sigma = n.getDouble("accel_bias_sigma", 0.0, 0.0, 1.0);
    model.imu.accel_bias_time = n.getDouble("accel_bias_time", 300.0, 1.0, 1e6);
    model.imu.stairs_vibration = n.getDouble("stairs_vibration", 0.0, 0.0, 20.0);
    model.imu.door_jolt = n.getDouble("door_jolt", 0.0, 0.0, 50.0);
    n.finish();
  }
  {
    const auto n = node.child("motion");
    MotionOptions& o = model.motion;
    o.speed = n.getDouble("speed", 0.05, 5.0);
    o.acceleration = n.getDouble("acceleration", 0.05, 10.0);
    o.turn_rate = n.getDouble("turn_rate_deg", 5.0, 720.0) * kDegree;
    o.angular_acceleration = n.getDouble("angular_acceleration_deg", 5.0, 3600.0) * kDegree;
    o.stairs_speed = n.getDouble("stairs_speed", 0.05, 2.0);
    o.elevator_speed = n.getDouble("elevator_speed", 0.1, 10.0);
    o.elevator_acceleration = n.getDouble("elevator_acceleration", 0.05, 5.0);
    o.door_time = n.getDouble("door_time", 0.0, 60.0);
    o.radius = n.getDouble("radius", 0.05, 2.0);
    n.finish();
  }
  node.finish();
  return model;
}

Scenario loadScenario(const std::string& path) {
  const auto root = common::ConfigNode::loadFile(path);
  const auto dir = std::filesystem::path(path).parent_path();
  Scenario scenario =
      readScenario(root, (dir / ".." / "robots").lexically_normal().string(), dir.string());
  scenario.path = path;
  return scenario;
}

Scenario loadScenarioString(const std::string& text, const std::string& name,
                            const std::string& robots_dir) {
  return readScenario(common::ConfigNode::loadString(text, name), robots_dir, "");
}

}  // namespace storey::sim
