#include "storey/sim/simulator.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <stdexcept>

#include "storey/sim/random.h"
#include "storey/sim/ray_caster.h"

namespace storey::sim {
namespace {

constexpr double kGravity = 9.80665;

// Independent random streams per robot and sensor, so adding a sensor or a robot does not
// change the others' noise.
// kOdometryStallStream is its own, so that stalls leave every other draw (and the poses
// odometry catches up to) as they were.
enum Stream : std::uint64_t {
  kLaserStream = 1,
  kOdometryStream,
  kPressureStream,
  kImuStream,
  kOdometryStallStream,
  kImuBiasStream
};
// Stairs rattle the robot once a step of this depth.
constexpr double kStepDepth = 0.3;  // m

// The floor's vertical acceleration u s after a door stopped: the second derivative of a
// small 10 Hz displacement in a 0.08 s Gaussian window around 0.2 s, so that the floor
// ends where and as still as it was (no net velocity or height), peaking near door_jolt.
double doorJolt(double u, const ImuOptions& o) {
  constexpr double kOmega = 2.0 * 3.14159265358979323846 * 10.0, kCentre = 0.2, kWidth = 0.08;
  const double amplitude = o.door_jolt / (kOmega * kOmega);
  auto x = [&](double v) {
    const double w = (v - kCentre) / kWidth;
    return amplitude * std::exp(-w * w) * std::sin(kOmega * (v - kCentre));
  };
  constexpr double h = 1e-3;
  return (x(u + h) - 2.0 * x(u) + x(u - h)) / (h * h);
}
constexpr std::uint64_t kWeatherStream = 0xA7;

std::uint64_t streamSeed(std::uint64_t seed, std::size_t robot, Stream stream) {
  return mixSeed(mixSeed(seed, 1000 + robot), stream);
}

// Sample times k / rate from the start to the end of the trajectory, inclusive.
std::vector<double> sampleTimes(double start, double end, double rate) {
  std::vector<double> times;
  const auto count = static_cast<std::size_t>(std::floor((end - start) * rate + 1e-9)) + 1;
  times.reserve(count);
  for (std::size_t k = 0; k < count; ++k) times.push_back(start + static_cast<double>(k) / rate);
  return times;
}

sensor::LaserScan emptyScan(const LaserOptions& laser) {
  sensor::LaserScan scan;
  const bool full_circle = laser.fov >= 2.0 * 3.14159265358979323846 - 1e-9;
  // A full circle must not repeat its first beam at the end.
  scan.angle_increment = laser.fov / (full_circle ? laser.beams : laser.beams - 1);
  scan.angle_min = -laser.fov / 2.0;
  scan.range_min = laser.min_range;
  scan.range_max = laser.max_range;
  scan.sensor_offset = laser.offset;
  scan.ranges.assign(laser.beams, std::numeric_limits<float>::infinity());
  return scan;
}

void fillRanges(const RayCaster& caster, const LaserOptions& laser, const geometry::Pose2& pose,
                sensor::LaserScan* scan, Rng* noise) {
  const geometry::Pose2 sensor = pose * laser.offset;
  const Eigen::Vector2d origin = sensor.translation();
  for (int i = 0; i < laser.beams; ++i) {
    const double angle = sensor.theta() + scan->angle(i);
    const Eigen::Vector2d dir(std::cos(angle), std::sin(angle));
    double range = caster.cast(origin, dir, laser.max_range);
    if (noise) {
      // Draw both numbers for every beam so one beam's outcome never shifts the others'.
      const double gaussian = noise->gaussian();
      const bool dropped = noise->uniform() < laser.dropout;
      if (std::isfinite(range)) range += gaussian * laser.range_sigma;
      if (dropped) range = std::numeric_limits<double>::infinity();
    }
    if (!std::isfinite(range) || range >= laser.max_range || range < laser.min_range)
      scan->ranges[i] = std::numeric_limits<float>::infinity();
    else
      scan->ranges[i] = static_cast<float>(range);
  }
}

RobotRun simulateRobot(const Scenario& scenario, std::size_t index, std::uint64_t seed,
                       double drift, double max_duration, bool without_barometer,
                       std::vector<std::unique_ptr<RayCaster>>* casters,
                       std::vector<SceneKey>* caster_keys) {
  const Building& building = scenario.building;
  const RobotSpec& spec = scenario.robots[index];
  const RobotModel& model = spec.model;
  RobotRun run;
  run.name = spec.name;
  run.trajectory = planMission(building, spec);
  const Trajectory& trajectory = run.trajectory;
  run.transits = trajectory.transits();
  const double start = trajectory.startTime();
  double end = trajectory.endTime();
  if (max_duration > 0.0) {
    end = std::min(end, start + max_duration);
    run.transits.erase(std::remove_if(run.transits.begin(), run.transits.end(),
                                      [&](const Transit& t) { return t.end > end; }),
                       run.transits.end());
  }

  // Ray casters are shared by robots that see the same scene.
  std::vector<const RayCaster*> scene_casters;
  for (const auto& key : trajectory.scenes()) {
    std::size_t k = 0;
    while (k < caster_keys->size() && !((*caster_keys)[k] == key)) ++k;
    if (k == caster_keys->size()) {
      caster_keys->push_back(key);
      casters->push_back(std::make_unique<RayCaster>(sceneObstacles(building, key)));
    }
    scene_casters.push_back((*casters)[k].get());
  }

  // Laser and truth.
  {
    Rng noise(streamSeed(seed, index, kLaserStream));
    const sensor::LaserScan blank = emptyScan(model.laser);
    for (double t : sampleTimes(start, end, model.laser.rate)) {
      const MotionState state = trajectory.at(t);
      sensor::LaserScan scan = blank;
      scan.stamp = t;
      fillRanges(*scene_casters[state.scene], model.laser, state.pose, &scan, &noise);
      run.scans.push_back(std::move(scan));
      run.truth.push_back({t, state.floor, state.pose, state.z});
    }
  }

  // Odometry: true increments in the robot frame with motion-proportional noise.
  {
    Rng noise(streamSeed(seed, index, kOdometryStream));
    const OdometryOptions& o = model.odometry;
    const auto& ride_ends = trajectory.rideEnds();
    std::size_t next_ride = 0;
    geometry::Pose2 estimate;
    geometry::Pose2 previous = trajectory.at(start).pose;
    Rng stalls(streamSeed(seed, index, kOdometryStallStream));
    auto nextStall = [&](double after) {
      return o.stall_interval > 0.0 ? after - o.stall_interval * std::log(1.0 - stalls.uniform())
                                    : std::numeric_limits<double>::infinity();
    };
    double stall_start = nextStall(start), stall_end = -std::numeric_limits<double>::infinity();
    sensor::OdometrySample held;  // the sample a stall repeats
    for (double t : sampleTimes(start, end, o.rate)) {
      const MotionState state = trajectory.at(t);
      const geometry::Pose2 delta = previous.between(state.pose);
      const double travelled = delta.translation().norm();
      const double g1 = noise.gaussian(), g2 = noise.gaussian(), g3 = noise.gaussian();
      // Variances grow linearly with the motion (sigma with its square root), so the
      // accumulated error does not depend on the odometry rate.
      const double error = g1 * o.translation_sigma * std::sqrt(travelled);
      const double scale = travelled > 0.0 ? 1.0 + error / travelled : 1.0;
      double dtheta = delta.theta() + g2 * o.rotation_sigma * std::sqrt(std::abs(delta.theta())) +
                      g3 * o.rotation_per_metre_sigma * std::sqrt(travelled);
      // Turning in a cabin while it moves makes wheel odometry slip.
      while (next_ride < ride_ends.size() && ride_ends[next_ride] <= t) {
        const double error = noise.gaussian() * o.elevator_heading_sigma;
        dtheta += error;
        // Rides are the elevator transits, in order.
        std::size_t ride = 0;
        for (auto& transit : run.transits)
          if (transit.mode == "elevator" && ride++ == next_ride)
            transit.odometry_heading_error = error;
        ++next_ride;
      }
      // Wheels measure the distance along a slope, not its horizontal projection.
      const double along = scale / std::cos(state.pitch);
      estimate = estimate * geometry::Pose2(delta.x() * along, delta.y() * along, dtheta);
      sensor::OdometrySample sample;
      sample.stamp = t;
      sample.pose = estimate;
      sample.linear_velocity = state.v;  // velocities are reported without noise
      sample.angular_velocity = state.omega;
      if (t >= stall_start && !run.odometry.empty()) {
        stall_end = stall_start + o.stall_duration;
        stall_start = nextStall(stall_end);
        held = run.odometry.back();
        ++run.odometry_stalls;
      }
      if (t < stall_end) {
        const double stamp = sample.stamp;
        sample = held;
        sample.stamp = stamp;
      }
      run.odometry.push_back(sample);
      previous = state.pose;
    }
  }

  // Barometer: standard atmosphere at the true height, weather drift, white noise.
  if (model.barometer.present && !without_barometer) {
    Rng noise(streamSeed(seed, index, kPressureStream));
    const double sigma = model.barometer.sigma;
    for (double t : sampleTimes(start, end, model.barometer.rate)) {
      const MotionState state = trajectory.at(t);
      sensor::PressureSample sample;
      sample.stamp = t;
      sample.pascal =
          pressureAt(building.atmosphere, state.z) + drift * t + noise.gaussian() * sigma;
      sample.variance = sigma * sigma;
      run.pressure.push_back(sample);
    }
  }

  // IMU: body-frame specific force (gravity included) and yaw rate; on a slope the body
  // pitches. The accelerometer's bias wanders (Gauss-Markov, its own stream).
  {
    Rng noise(streamSeed(seed, index, kImuStream));
    Rng bias_noise(streamSeed(seed, index, kImuBiasStream));
    const ImuOptions& o = model.imu;
    Eigen::Vector3d bias(bias_noise.gaussian(), bias_noise.gaussian(), bias_noise.gaussian());
    bias *= o.accel_bias_sigma;
    const double decay = std::exp(-1.0 / (o.rate * o.accel_bias_time));
    const double kick = o.accel_bias_sigma * std::sqrt(1.0 - decay * decay);
    const std::vector<double>& doors = trajectory.doorMoves();
    std::size_t next_door = 0;
    for (double t : sampleTimes(start, end, o.rate)) {
      const MotionState state = trajectory.at(t);
      sensor::ImuSample sample;
      sample.stamp = t;
      const double n1 = noise.gaussian(), n2 = noise.gaussian(), n3 = noise.gaussian();
      const double n4 = noise.gaussian(), n5 = noise.gaussian(), n6 = noise.gaussian();
      const double c = std::cos(state.pitch), s = std::sin(state.pitch);
      double forward = state.a * c + (kGravity + state.az) * s;
      double up = -state.a * s + (kGravity + state.az) * c;
      if (state.pitch != 0.0 && o.stairs_vibration > 0.0) {
        const double bump = o.stairs_vibration * std::sin(2.0 * 3.14159265358979323846 *
                                                          state.travelled / (kStepDepth * c));
        forward += 0.5 * bump;
        up += bump;
      }
      while (next_door < doors.size() && doors[next_door] + 0.5 < t) ++next_door;
      if (next_door < doors.size() && t >= doors[next_door])
        up += doorJolt(t - doors[next_door], o);
      sample.linear_acceleration =
          Eigen::Vector3d(forward + n1 * o.accel_sigma, state.v * state.omega + n2 * o.accel_sigma,
                          up + n3 * o.accel_sigma) +
          bias;
      for (int k = 0; k < 3; ++k) bias[k] = decay * bias[k] + kick * bias_noise.gaussian();
      sample.angular_velocity =
          Eigen::Vector3d(n4 * o.gyro_sigma, n5 * o.gyro_sigma, state.omega + n6 * o.gyro_sigma);
      run.imu.push_back(sample);
    }
  }
  return run;
}

}  // namespace

sensor::LaserScan castScan(const std::vector<Segment>& obstacles, const LaserOptions& laser,
                           const geometry::Pose2& pose) {
  RayCaster caster(obstacles);
  sensor::LaserScan scan = emptyScan(laser);
  fillRanges(caster, laser, pose, &scan, nullptr);
  return scan;
}

Simulation simulate(const Scenario& scenario, const SimulateOptions& options) {
  Simulation result;
  result.scenario = scenario.name;
  result.seed = options.seed;
  result.building = scenario.building;
  // The weather: one steady pressure trend per run, shared by every robot.
  Rng weather(mixSeed(options.seed, kWeatherStream));
  const double max_drift = scenario.building.atmosphere.max_drift_hpa_per_hour * 100.0 / 3600.0;
  result.pressure_drift = weather.uniform(-max_drift, max_drift);
  for (const auto& name : options.robots) {
    bool found = false;
    for (const auto& robot : scenario.robots) found = found || robot.name == name;
    if (!found)
      throw std::invalid_argument("scenario " + scenario.name + " has no robot '" + name + "'");
  }
  std::vector<std::unique_ptr<RayCaster>> casters;
  std::vector<SceneKey> keys;
  for (std::size_t i = 0; i < scenario.robots.size(); ++i) {
    const auto& name = scenario.robots[i].name;
    if (!options.robots.empty() &&
        std::find(options.robots.begin(), options.robots.end(), name) == options.robots.end())
      continue;
    result.robots.push_back(simulateRobot(scenario, i, options.seed, result.pressure_drift,
                                          options.max_duration, options.without_barometer, &casters,
                                          &keys));
  }
  return result;
}

}  // namespace storey::sim
