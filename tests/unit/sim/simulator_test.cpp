#include "storey/sim/simulator.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <string>

#include "storey/sim/ray_caster.h"
#include "test_support.h"

namespace storey::sim {
namespace {

std::string small2Path() { return test::sourceDir() + "/config/buildings/small2.yaml"; }

template <typename T>
void appendBytes(std::string* out, const T& value) {
  out->append(reinterpret_cast<const char*>(&value), sizeof(T));
}

// Every number the simulation produced, as raw bytes.
std::string serialize(const Simulation& run) {
  std::string out;
  appendBytes(&out, run.pressure_drift);
  for (const auto& robot : run.robots) {
    for (const auto& scan : robot.scans) {
      appendBytes(&out, scan.stamp);
      appendBytes(&out, scan.angle_min);
      appendBytes(&out, scan.angle_increment);
      out.append(reinterpret_cast<const char*>(scan.ranges.data()),
                 scan.ranges.size() * sizeof(float));
    }
    for (const auto& o : robot.odometry) {
      for (double v :
           {o.stamp, o.pose.x(), o.pose.y(), o.pose.theta(), o.linear_velocity, o.angular_velocity})
        appendBytes(&out, v);
    }
    for (const auto& p : robot.pressure) {
      appendBytes(&out, p.stamp);
      appendBytes(&out, p.pascal);
    }
    for (const auto& i : robot.imu) {
      appendBytes(&out, i.stamp);
      for (int k = 0; k < 3; ++k) {
        appendBytes(&out, i.linear_acceleration[k]);
        appendBytes(&out, i.angular_velocity[k]);
      }
    }
    for (const auto& t : robot.truth) {
      for (double v : {t.stamp, t.pose.x(), t.pose.y(), t.pose.theta(), t.z}) appendBytes(&out, v);
      appendBytes(&out, t.floor);
    }
  }
  return out;
}

class Small2 : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    scenario_ = new Scenario(loadScenario(small2Path()));
    run_ = new Simulation(simulate(*scenario_, 42));
  }
  static void TearDownTestSuite() {
    delete run_;
    delete scenario_;
  }
  static Scenario* scenario_;
  static Simulation* run_;
};
Scenario* Small2::scenario_ = nullptr;
Simulation* Small2::run_ = nullptr;

TEST_F(Small2, IsSmallEnoughForTheDefaultMappingJob) {
  ASSERT_EQ(run_->robots.size(), 1u);
  const RobotRun& robot = run_->robots[0];
  const double duration = robot.truth.back().stamp - robot.truth.front().stamp;
  std::printf("small2: %zu scans over %.1f s, %zu odometry, %zu pressure, %zu imu samples\n",
              robot.scans.size(), duration, robot.odometry.size(), robot.pressure.size(),
              robot.imu.size());
  EXPECT_GE(robot.scans.size(), 300u);
  EXPECT_LE(robot.scans.size(), 600u);
  EXPECT_GE(duration, 100.0);
  EXPECT_LE(duration, 200.0);
  EXPECT_EQ(robot.truth.size(), robot.scans.size());
}

TEST_F(Small2, SameSeedGivesIdenticalBytesAndAnotherSeedDoesNot) {
  const std::string first = serialize(*run_);
  const std::string again = serialize(simulate(*scenario_, 42));
  ASSERT_EQ(first.size(), again.size());
  EXPECT_TRUE(first == again);
  const std::string other = serialize(simulate(*scenario_, 43));
  EXPECT_FALSE(first == other);
}

TEST_F(Small2, StreamsAreTimeOrdered) {
  for (const auto& robot : run_->robots) {
    for (std::size_t i = 1; i < robot.scans.size(); ++i)
      EXPECT_GT(robot.scans[i].stamp, robot.scans[i - 1].stamp);
    for (std::size_t i = 1; i < robot.odometry.size(); ++i)
      EXPECT_GT(robot.odometry[i].stamp, robot.odometry[i - 1].stamp);
    for (std::size_t i = 1; i < robot.pressure.size(); ++i)
      EXPECT_GT(robot.pressure[i].stamp, robot.pressure[i - 1].stamp);
    for (std::size_t i = 1; i < robot.imu.size(); ++i)
      EXPECT_GT(robot.imu[i].stamp, robot.imu[i - 1].stamp);
  }
}

TEST_F(Small2, TransitsAreOneElevatorRideUpAndOneStairClimbDown) {
  const RobotRun& robot = run_->robots[0];
  ASSERT_EQ(robot.transits.size(), 2u);
  EXPECT_EQ(robot.transits[0].mode, "elevator");
  EXPECT_EQ(robot.transits[0].from_floor, 0);
  EXPECT_EQ(robot.transits[0].to_floor, 1);
  EXPECT_EQ(robot.transits[1].mode, "stairs");
  EXPECT_EQ(robot.transits[1].from_floor, 1);
  EXPECT_EQ(robot.transits[1].to_floor, 0);
  // A 3.5 m ride at 1 m/s with 0.5 m/s^2: 2 s up to speed (1 m), 1.5 m cruising, 2 s braking.
  EXPECT_NEAR(robot.transits[0].end - robot.transits[0].start, 5.5, 1e-9);
  // Truth follows: floor F0 before the ride, F1 between ride and climb, F0 after.
  for (const auto& t : robot.truth) {
    const int expected = t.stamp < robot.transits[0].end   ? 0
                         : t.stamp < robot.transits[1].end ? 1
                                                           : 0;
    EXPECT_EQ(t.floor, expected) << "at " << t.stamp;
    if (t.stamp <= robot.transits[0].start) {
      EXPECT_DOUBLE_EQ(t.z, 0.0);
    }
    if (t.stamp >= robot.transits[0].end && t.stamp <= robot.transits[1].start) {
      EXPECT_DOUBLE_EQ(t.z, 3.5);
    }
  }
}

TEST_F(Small2, PressureFallsAboutTwelvePascalPerMetreUpstairs) {
  const RobotRun& robot = run_->robots[0];
  const Transit& up = robot.transits[0];
  const Transit& down = robot.transits[1];
  double below = 0.0, above = 0.0;
  int n_below = 0, n_above = 0;
  for (const auto& p : robot.pressure) {
    if (p.stamp < up.start && p.stamp > up.start - 20.0) below += p.pascal, ++n_below;
    if (p.stamp > up.end && p.stamp < up.end + 20.0) above += p.pascal, ++n_above;
  }
  ASSERT_GT(n_below, 50);
  ASSERT_GT(n_above, 50);
  const double per_metre = (below / n_below - above / n_above) / 3.5;
  EXPECT_NEAR(per_metre, 12.0, 0.6);
  EXPECT_NEAR(pressureAt(scenario_->building.atmosphere, 0.0) -
                  pressureAt(scenario_->building.atmosphere, 1.0),
              12.0, 0.3);
  // Weather drift stays within the declared bound.
  EXPECT_LE(std::abs(run_->pressure_drift) * 3600.0, 50.0 + 1e-9);
  (void)down;
}

TEST_F(Small2, ImuFeelsGravityAndTheRide) {
  const RobotRun& robot = run_->robots[0];
  const Transit& up = robot.transits[0];
  double rest = 0.0, accelerating = 0.0;
  int n_rest = 0, n_acc = 0;
  for (const auto& s : robot.imu) {
    if (s.stamp < up.start - 0.5 && s.stamp > up.start - 2.0)
      rest += s.linear_acceleration.z(), ++n_rest;
    if (s.stamp > up.start + 0.1 && s.stamp < up.start + 1.9)
      accelerating += s.linear_acceleration.z(), ++n_acc;
  }
  ASSERT_GT(n_rest, 10);
  ASSERT_GT(n_acc, 10);
  EXPECT_NEAR(rest / n_rest, 9.80665, 0.05);
  EXPECT_NEAR(accelerating / n_acc, 9.80665 + 0.5, 0.05);
}

// An elevator door that stops shakes the floor (door_jolt 2 m/s^2 in default.yaml) but
// leaves it where it was: the vertical force less its level and the cabin's own
// acceleration (a ride may start at once) integrates to no velocity.
TEST_F(Small2, AnElevatorDoorShakesTheFloorWithoutMovingIt) {
  const RobotRun& robot = run_->robots[0];
  const auto& doors = robot.trajectory.doorMoves();
  ASSERT_EQ(doors.size(), 3u);  // landing door opens, closes behind the robot, opens above
  for (double door : doors) {
    double level = 0.0, peak = 0.0, velocity = 0.0;
    int n = 0;
    for (const auto& s : robot.imu)
      if (s.stamp > door - 1.0 && s.stamp < door) {
        level += s.linear_acceleration.z();
        ++n;
      }
    ASSERT_GT(n, 10);
    level /= n;
    for (const auto& s : robot.imu)
      if (s.stamp >= door && s.stamp < door + 0.5) {
        const double jolt = s.linear_acceleration.z() - level - robot.trajectory.at(s.stamp).az;
        peak = std::max(peak, std::abs(jolt));
        velocity += jolt * 0.02;
      }
    EXPECT_GT(peak, 1.0) << "door at " << door;
    EXPECT_LT(std::abs(velocity), 0.01) << "door at " << door;
  }
}

TEST_F(Small2, NoiselessScansAtTruthMatchTheRecordedScans) {
  const RobotRun& robot = run_->robots[0];
  const LaserOptions& laser = scenario_->robots[0].model.laser;
  int compared = 0, close = 0;
  for (std::size_t i = 0; i < robot.scans.size(); i += 25) {
    const MotionState state = robot.trajectory.at(robot.truth[i].stamp);
    const auto obstacles = sceneObstacles(run_->building, robot.trajectory.scenes()[state.scene]);
    const auto clean = castScan(obstacles, laser, robot.truth[i].pose);
    for (std::size_t b = 0; b < clean.size(); ++b) {
      if (!clean.isReturn(b) || !robot.scans[i].isReturn(b)) continue;
      ++compared;
      close += std::abs(clean.ranges[b] - robot.scans[i].ranges[b]) < 5.0 * laser.range_sigma;
    }
  }
  ASSERT_GT(compared, 1000);
  EXPECT_GT(static_cast<double>(close) / compared, 0.99);
}

TEST_F(Small2, OdometryDriftsButStaysNearTruth) {
  const RobotRun& robot = run_->robots[0];
  // Odometry starts at the identity at the start pose: compare relative motion.
  const geometry::Pose2 start = robot.truth.front().pose;
  const geometry::Pose2 true_end = start.between(robot.truth.back().pose);
  const geometry::Pose2 odom_end = robot.odometry.back().pose;
  const double error = (true_end.translation() - odom_end.translation()).norm();
  std::printf("small2 odometry end-point error %.2f m, heading %.2f deg\n", error,
              geometry::angleDiff(true_end.theta(), odom_end.theta()) * 180.0 / 3.14159265);
  EXPECT_GT(error, 1e-3);  // noise is on
  EXPECT_LT(error, 10.0);
}

// Odometry that stalls now and then: while it does, the published pose repeats the last one;
// after, it is the pose it would have been, and every other stream is unchanged.
TEST_F(Small2, OdometryStallsHoldThePoseThenCatchUp) {
  Scenario stalling = *scenario_;
  stalling.robots[0].model.odometry.stall_interval = 10.0;
  stalling.robots[0].model.odometry.stall_duration = 0.5;
  const Simulation run = simulate(stalling, 42);
  const RobotRun& with = run.robots[0];
  const RobotRun& without = run_->robots[0];
  EXPECT_EQ(without.odometry_stalls, 0u);
  const double duration = with.odometry.back().stamp - with.odometry.front().stamp;
  EXPECT_GT(with.odometry_stalls, duration / 10.0 / 2.0);
  EXPECT_LT(with.odometry_stalls, duration / 10.0 * 2.0);
  ASSERT_EQ(with.odometry.size(), without.odometry.size());
  std::size_t held = 0, caught_up_moving = 0;
  for (std::size_t i = 1; i < with.odometry.size(); ++i) {
    const auto& a = with.odometry[i];
    const auto& b = without.odometry[i];
    EXPECT_EQ(a.stamp, b.stamp);
    const bool same =
        a.pose.x() == b.pose.x() && a.pose.y() == b.pose.y() && a.pose.theta() == b.pose.theta();
    if (same) continue;
    // Not the undisturbed pose: then it repeats the one before.
    const auto& previous = with.odometry[i - 1];
    EXPECT_TRUE(a.pose.x() == previous.pose.x() && a.pose.y() == previous.pose.y() &&
                a.pose.theta() == previous.pose.theta())
        << "sample " << i;
    ++held;
    if (i + 1 < with.odometry.size() &&
        with.odometry[i + 1].pose.x() == without.odometry[i + 1].pose.x() &&
        (b.pose.translation() - a.pose.translation()).norm() > 0.05)
      ++caught_up_moving;
  }
  // 20 Hz: a 0.5 s stall holds 10 samples (fewer where the robot stood still anyway).
  EXPECT_LE(held, with.odometry_stalls * 10);
  EXPECT_GT(held, with.odometry_stalls * 3);
  EXPECT_GT(caught_up_moving, 0u);  // some stalls happened while it drove
  // The other streams do not see the stalls.
  Simulation others = run;
  Simulation reference = *run_;
  others.robots[0].odometry.clear();
  reference.robots[0].odometry.clear();
  EXPECT_TRUE(serialize(others) == serialize(reference));
}

TEST_F(Small2, TheLaserSeesOnlyTheCabinDuringTheRide) {
  const RobotRun& robot = run_->robots[0];
  const Transit& up = robot.transits[0];
  int scans = 0;
  for (std::size_t i = 0; i < robot.scans.size(); ++i) {
    if (robot.scans[i].stamp <= up.start || robot.scans[i].stamp >= up.end) continue;
    ++scans;
    for (std::size_t b = 0; b < robot.scans[i].size(); ++b)
      if (robot.scans[i].isReturn(b)) {
        EXPECT_LT(robot.scans[i].ranges[b], 1.6);  // 2 m x 2 m cabin
      }
  }
  EXPECT_GT(scans, 5);
}

TEST(Profile, ReachesTheDistanceWithTheDeclaredLimits) {
  const Profile cruise = Profile::make(10.0, 1.0, 0.5);
  EXPECT_NEAR(cruise.duration(), 12.0, 1e-12);  // 2 s + 8 s + 2 s
  double s, v, a;
  cruise.at(cruise.duration(), &s, &v, &a);
  EXPECT_NEAR(s, 10.0, 1e-12);
  EXPECT_NEAR(v, 0.0, 1e-12);
  cruise.at(6.0, &s, &v, &a);
  EXPECT_NEAR(s, 5.0, 1e-12);
  EXPECT_NEAR(v, 1.0, 1e-12);
  const Profile triangle = Profile::make(1.0, 1.0, 0.5);  // never reaches 1 m/s
  EXPECT_NEAR(triangle.duration(), 2.0 * std::sqrt(2.0), 1e-12);
  triangle.at(triangle.duration() / 2.0, &s, &v, &a);
  EXPECT_NEAR(s, 0.5, 1e-12);
  EXPECT_LT(v, 1.0);
}

}  // namespace
}  // namespace storey::sim
