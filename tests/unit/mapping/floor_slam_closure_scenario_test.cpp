// FloorSlam's loop closures on synthetic worlds: drift corrected, clusters, the region check.
#include <gtest/gtest.h>

#include <cstdio>
#include <limits>

#include "bare_options.h"
#include "storey/mapping/floor_slam.h"
#include "synthetic_world.h"
#include "test_support.h"
#include "world_run.h"

namespace storey::mapping {
using eval::OdometryNoise;
using eval::simulateOdometry;
namespace {

using geometry::Pose2;
using test::maxTranslationError;
using test::pathThrough;
using test::runWorld;
using test::WorldRun;

TEST(FloorSlam, LoopClosureCorrectsDrift) {
  const test::World world = test::ringCorridorWorld();
  const auto truth = pathThrough({{1, 1}, {23, 1}, {23, 15}, {1, 15}, {1, 1}, {12, 1}});
  OdometryNoise noise;
  noise.rotation_per_meter = 3.0 * M_PI / 180;
  FloorSlamOptions with = test::bareOptions();
  FloorSlamOptions rebuilding = with;  // a fresh candidate map for every attempt
  rebuilding.loop_closure.submap_reuse_nodes = 0;
  FloorSlamOptions without = test::bareOptions();
  without.loop_closure.enabled = false;
  const WorldRun closed = runWorld(world, truth, with, 11, noise);
  const WorldRun closed_rebuilding = runWorld(world, truth, rebuilding, 11, noise);
  const WorldRun open = runWorld(world, truth, without, 11, noise);
  EXPECT_GE(closed.stats.loop_closures, 1u);
  EXPECT_GE(closed_rebuilding.stats.loop_closures, 1u);
  // Reusing the last candidate map for nearby candidates builds fewer maps than reusing it
  // for the same candidate only (every accepted closure moves the nodes and forces a new one).
  EXPECT_EQ(closed.stats.loop_attempts, closed_rebuilding.stats.loop_attempts);
  EXPECT_LT(closed.stats.loop_maps_built, closed_rebuilding.stats.loop_maps_built);
  EXPECT_LT(closed_rebuilding.stats.loop_maps_built, closed_rebuilding.stats.loop_attempts);
  if (std::getenv("STOREY_DEBUG_LOOP")) {
    for (std::size_t i = 0; i < closed.truth.size(); i += 5)
      std::printf("%zu truth %.2f %.2f est %.2f %.2f open %.2f %.2f\n", i, closed.truth[i].x(),
                  closed.truth[i].y(), closed.estimate[i].x(), closed.estimate[i].y(),
                  open.estimate[i].x(), open.estimate[i].y());
  }
  // Back at the start, the closed loop knows where it is relative to its first pass (the
  // pose at the same place on the first leg); the open one has drifted.
  std::size_t first_pass = 0;
  for (std::size_t i = 0; i < truth.size() / 2; ++i)
    if ((truth[i].translation() - truth.back().translation()).norm() <
        (truth[first_pass].translation() - truth.back().translation()).norm())
      first_pass = i;
  auto loopError = [&](const WorldRun& r) {
    const Pose2 e = r.truth[first_pass]
                        .between(r.truth.back())
                        .between(r.estimate[first_pass].between(r.estimate.back()));
    return e.translation().norm();
  };
  EXPECT_LT(loopError(closed), 0.1);
  EXPECT_LT(loopError(closed_rebuilding), 0.1);
  EXPECT_GT(loopError(open), 0.3);
  // Known weakness (docs/floor_mapper.md): in this long, nearly featureless ring only
  // odometry constrains the corridors' axes, and the optimiser spreads the closure's
  // correction over them, so the absolute error does not drop as much as the loop error.
}

TEST(FloorSlam, ALargeDriftIsClosedByClosuresThatAgree) {
  // A ring whose first leg is a bare corridor where the wheels slip: odometry says 8 % more
  // than was driven, and the scans cannot tell (only the walls along it are in range). Back
  // at the start the graph is metres off; no single closure may move it that far, a
  // cluster of closures that agree does.
  test::World world;
  world.addBox(0, 0, 40, 14);
  world.addBox(2, 2, 38, 12);
  for (double x = 1; x < 40; x += 7.3)
    world.addBox(x, 13.6, x + 0.4, 13.95);  // doors on the far leg
  world.addBox(38.1, 5, 38.5, 5.6);
  world.addBox(1.6, 7, 1.95, 7.5);
  world.addBox(0.05, 3, 0.4, 3.4);
  world.addWall(0.5, 0, 0.5, 0.4);
  const auto truth = pathThrough({{1, 1}, {39, 1}, {39, 13}, {1, 13}, {1, 1}, {10, 1}});
  // Slip on the first leg: every step there 8 % longer than driven, built step by step so
  // that each slipped step carries on from the last.
  const std::vector<Pose2> simulated = simulateOdometry(truth, OdometryNoise{}, 5);
  std::vector<Pose2> odometry = {simulated.front()};
  for (std::size_t i = 1; i < truth.size(); ++i) {
    Pose2 step = simulated[i - 1].between(simulated[i]);
    if (truth[i].y() < 1.5 && truth[i].x() < 38.9 && i < truth.size() / 2)
      step = Pose2(step.x() * 1.08, step.y(), step.theta());
    odometry.push_back(odometry.back() * step);
  }
  auto run = [&](int cluster_size) {
    FloorSlamOptions options = test::bareOptions();
    options.loop_closure.cluster_size = cluster_size;
    return runWorld(world, truth, options, odometry);
  };
  const WorldRun clustered = run(3), alone = run(1);
  std::printf(
      "clusters %zu closures %zu of %zu, max error %.2f m; closures alone: %zu of %zu, max error "
      "%.2f m\n",
      clustered.stats.loop_clusters, clustered.stats.loop_closures, clustered.stats.loop_attempts,
      maxTranslationError(clustered), alone.stats.loop_closures, alone.stats.loop_attempts,
      maxTranslationError(alone));
  // Where the robot is, relative to the start, when it is back at the start corner (the loop
  // the closures close), and where it ended, 9 m along the first leg again.
  auto errorAt = [](const WorldRun& r, std::size_t k) {
    return (r.truth.front().between(r.truth[k]).translation() -
            r.estimate.front().between(r.estimate[k]).translation())
        .norm();
  };
  std::size_t back = truth.size() / 2;
  while (back < truth.size() &&
         (truth[back].translation() - truth.front().translation()).norm() > 0.2)
    ++back;
  ASSERT_LT(back, truth.size());
  const std::size_t end = truth.size() - 1;
  std::printf("back at the start: error %.2f m, alone %.2f m; at the end %.2f m, alone %.2f m\n",
              errorAt(clustered, back), errorAt(alone, back), errorAt(clustered, end),
              errorAt(alone, end));
  // Achieved: back at the start 0.78 m with clusters (6 clusters, 12 closures), 2.41 m with
  // closures alone (6 of 23). At the end, 9 m into the bare first leg, 0.75 m and 1.58 m:
  // nothing in that corridor tells its length, so the graph keeps the leg's 8 % stretch
  // there (0.72 m over 9 m). With 3 m of slip the optimiser spreads the correction by
  // bending the legs (largest error 2.60 m), the weakness LoopClosureCorrectsDrift notes.
  EXPECT_GE(clustered.stats.loop_clusters, 1u);
  EXPECT_LT(errorAt(clustered, back), 1.0);
  EXPECT_GT(errorAt(alone, back), 1.5);
}

// A 60 m x 14 m ring corridor, 2 m wide, whose bottom leg has pillars every `period` on both
// walls from x = first_pillar on; a few features elsewhere so the other legs can be tracked.
const double kRingLength = 60.0;
test::World ringWithPillars(double period, double first_pillar) {
  test::World world;
  world.addBox(0, 0, kRingLength, 14);
  world.addBox(2, 2, kRingLength - 2, 12);
  for (double x = first_pillar; x < kRingLength - 3; x += period) {
    world.addBox(x, 0.05, x + 0.4, 0.4);
    world.addBox(x + 1, 1.6, x + 1.4, 1.95);
  }
  world.addBox(kRingLength - 1.9, 5, kRingLength - 1.5, 5.6);
  world.addBox(1.6, 7, 1.95, 7.5);
  world.addBox(0.05, 9, 0.4, 9.4);
  return world;
}

// Once round the ring and back along the bottom leg to x = 28.
std::vector<Pose2> ringPath() {
  return pathThrough(
      {{1, 1}, {kRingLength - 1, 1}, {kRingLength - 1, 13}, {1, 13}, {1, 1}, {28, 1}});
}

// Simulated odometry (seed 5) whose steps on the bare top leg are scaled by `slip`, built
// step by step.
std::vector<Pose2> slipOnTopLeg(const std::vector<Pose2>& truth, double slip) {
  const std::vector<Pose2> simulated = simulateOdometry(truth, OdometryNoise{}, 5);
  std::vector<Pose2> odometry = {simulated.front()};
  for (std::size_t i = 1; i < truth.size(); ++i) {
    Pose2 step = simulated[i - 1].between(simulated[i]);
    if (truth[i].y() > 12.5 && truth[i].x() > 1.1 && truth[i].x() < kRingLength - 1.1)
      step = Pose2(step.x() * slip, step.y(), step.theta());
    odometry.push_back(odometry.back() * step);
  }
  return odometry;
}

// A closure's error against the truth (m).
double closureError(const WorldRun& r, const LoopClosureAttempt& a) {
  return r.node_truth[a.candidate]
      .between(r.node_truth[a.node])
      .between(a.measurement)
      .translation()
      .norm();
}

// Where the robot ended along the bottom leg relative to its start, error (m).
double endAlongError(const WorldRun& r) {
  return r.estimate.front().between(r.estimate.back()).x() -
         r.truth.front().between(r.truth.back()).x();
}

TEST(FloorSlam, ARegionCheckKeepsClosuresOffALookAlikeStretch) {
  // A 60 m x 14 m ring whose bottom leg has pillars every 7 m on both walls, and one wide
  // niche-like block that breaks the pattern. The top leg is bare and the wheels slip there:
  // odometry says 15 % more than was driven. Back on the bottom leg the graph is about one
  // period (7 m) behind along the corridor, beyond the closures' match window (4 m), so
  // every closure finds the pillars one period off, and those closures agree with each
  // other. The region check searches the last scans, joined, over the whole region the
  // graph's uncertainty allows (here about 15 m): the true place fits better (the block).
  const double period = 7.0;
  test::World world = ringWithPillars(period, 3.0);
  world.addBox(12, 0.05, 13.5, 0.6);  // the irregularity
  const auto truth = ringPath();
  const std::vector<Pose2> odometry = slipOnTopLeg(truth, 1.15);
  auto run = [&](double verify_window) {
    FloorSlamOptions options =
        test::bareOptions();  // max_linear_window 4 m, cluster_verify_distance 4 m
    options.loop_closure.cluster_verify_window = verify_window;
    return runWorld(world, truth, options, odometry);
  };
  struct Figures {
    int accepted = 0, relocated = 0;
    double worst = 0.0;  // largest error of an accepted closure against the truth (m)
    double along =
        0.0;  // where the robot ended along the bottom leg relative to its start, error (m)
  };
  auto figures = [](const WorldRun& r) {
    Figures f;
    for (const auto& a : r.attempts) {
      if (a.outcome != LoopOutcome::kAccepted) continue;
      ++f.accepted;
      f.relocated += a.relocated ? 1 : 0;
      f.worst = std::max(f.worst, closureError(r, a));
    }
    f.along = endAlongError(r);
    return f;
  };
  const WorldRun off = run(0.0), on = run(30.0);
  const Figures f_off = figures(off), f_on = figures(on);
  auto print = [](const char* name, const WorldRun& r, const Figures& f) {
    std::printf(
        "%s: clusters %zu (refused %zu), closures %d of %zu (relocated %d), worst closure %.2f m, "
        "end along %.2f m, max error %.2f m\n",
        name, r.stats.loop_clusters, r.stats.loop_clusters_ambiguous, f.accepted,
        r.stats.loop_attempts, f.relocated, f.worst, f.along, maxTranslationError(r));
  };
  print("check off", off, f_off);
  print("check on ", on, f_on);
  // Achieved: off, one cluster 7.06 m wrong (one period), the end 6.96 m short along the
  // leg; on, 3 clusters refused and 3 closures relocated, the worst of 25 closures 0.06 m
  // off, the end 0.01 m along. (The largest error anywhere is no better, 12.6 m against
  // 7.0: the optimiser spreads the 7 m correction by bending the legs across, the weakness
  // noted in LoopClosureCorrectsDrift; so it is not asserted.)
  // Without the check a cluster one period off goes in, and the end is a period off.
  EXPECT_GE(off.stats.loop_clusters, 1u);
  EXPECT_GT(f_off.worst, 0.7 * period);
  EXPECT_GT(std::abs(f_off.along), 0.7 * period);
  // With it the wrong clusters are refused, the newest closures moved to the true place,
  // and every closure that goes in is right.
  EXPECT_GE(on.stats.loop_clusters_ambiguous, 1u);
  EXPECT_GE(on.stats.loop_clusters, 1u);
  EXPECT_GE(f_on.relocated, 1);
  EXPECT_GT(f_on.accepted, 10);
  EXPECT_LT(f_on.worst, 0.2);
  EXPECT_LT(std::abs(f_on.along), 0.5);
}

TEST(FloorSlam, ALoneClosureNeedsAUniquePlaceWhileTheGraphIsLost) {
  // A 60 m x 14 m ring whose bottom leg has pillars every 2.5 m on both walls from x = 10 on
  // (no irregularity). The top leg is bare and the wheels slip there the other way: odometry
  // says 6 % less than was driven, so back at the bottom-left corner the graph has the robot
  // about one period (2.5 m) ahead along the bottom leg, with σ near 5 m: the closures'
  // window is at its cap (4 m), and both the true place and the look-alike one period on lie
  // in it. The match near the graph's prediction is the look-alike, a small correction,
  // which goes in alone and confirms the wrong place. With single_unique_distance the other
  // place in the window holds it for a cluster, and the closures that follow, at the true
  // place, close the loop together.
  const double period = 2.5;
  const test::World world = ringWithPillars(period, 10.0);
  const auto truth = ringPath();
  const std::vector<Pose2> odometry = slipOnTopLeg(truth, 0.94);
  auto run = [&](double unique_distance) {
    FloorSlamOptions options = test::bareOptions();  // max_linear_window 4 m, the region check on
    options.loop_closure.cluster_verify_window = 30.0;
    options.loop_closure.single_unique_distance = unique_distance;
    return runWorld(world, truth, options, odometry);
  };
  struct Figures {
    int accepted = 0, not_unique = 0;
    double worst = 0.0;  // largest error of an accepted closure against the truth (m)
    // The worst closure that went in alone while the window was at its cap.
    double capped_alone = 0.0, capped_alone_sigma = 0.0, capped_alone_correction = 0.0;
    double along =
        0.0;  // where the robot ended along the bottom leg relative to its start, error (m)
  };
  const double cap = test::bareOptions().loop_closure.max_linear_window;
  auto figures = [&](const WorldRun& r) {
    Figures f;
    for (const auto& a : r.attempts) {
      f.not_unique += a.not_unique ? 1 : 0;
      if (a.outcome != LoopOutcome::kAccepted) continue;
      ++f.accepted;
      const double e = closureError(r, a);
      f.worst = std::max(f.worst, e);
      if (a.together == 1 && a.linear_window >= cap && e > f.capped_alone) {
        f.capped_alone = e;
        f.capped_alone_sigma = a.sigma;
        f.capped_alone_correction = a.correction().translation().norm();
      }
    }
    f.along = endAlongError(r);
    return f;
  };
  const WorldRun off = run(0.0), on = run(1.0);
  const Figures f_off = figures(off), f_on = figures(on);
  auto print = [](const char* name, const WorldRun& r, const Figures& f) {
    std::printf(
        "%s: closures %d of %zu (clusters %zu), not unique %d, worst closure %.2f m; worst alone "
        "at the "
        "cap %.2f m (sigma %.2f m, correction %.2f m); end along %.2f m, max error %.2f m\n",
        name, f.accepted, r.stats.loop_attempts, r.stats.loop_clusters, f.not_unique, f.worst,
        f.capped_alone, f.capped_alone_sigma, f.capped_alone_correction, f.along,
        maxTranslationError(r));
  };
  print("unique check off", off, f_off);
  print("unique check on ", on, f_on);
  // Achieved: off, a closure at the corner went in alone 2.51 m (one period) wrong with a
  // 0.08 m correction at σ 4.80 m, and the rest followed it (37 closures, all alone, the worst
  // 2.55 m off, the end 2.51 m along); on, that closure was held (1 not unique), the next
  // three, at the true place, went in as a cluster, the worst of 36 closures 0.04 m off, the
  // end 0.01 m along. (The largest error anywhere is worse, 6.06 m against 2.83: the optimiser
  // spreads the 2.5 m correction by bending the legs across, the weakness noted in
  // LoopClosureCorrectsDrift; so it is not asserted.) The world is narrow: with 6.5 % slip
  // instead of 6 % nothing in the window scores 0.9 of the match and the wrong closure goes in
  // with the check on too (5.5 %, or seed 6, behave as here).
  EXPECT_GT(f_off.capped_alone, 0.7 * period);
  EXPECT_GE(f_off.capped_alone_sigma, 1.0);  // 1 m + 3σ >= 4 m: the window at its cap
  EXPECT_LE(f_off.capped_alone_correction, test::bareOptions().loop_closure.single_max_translation);
  EXPECT_GT(std::abs(f_off.along), 0.7 * period);
  EXPECT_EQ(off.stats.loop_clusters, 0u);
  EXPECT_GE(f_on.not_unique, 1);
  EXPECT_GE(on.stats.loop_clusters, 1u);
  EXPECT_GT(f_on.accepted, 10);
  EXPECT_LT(f_on.worst, 0.5);
  EXPECT_LT(std::abs(f_on.along), 0.5);
}

}  // namespace
}  // namespace storey::mapping
