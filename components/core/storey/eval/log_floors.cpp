#include "storey/eval/log_floors.h"

#include <algorithm>
#include <cmath>
#include <optional>
#include <random>
#include <string>

namespace storey::eval {

using geometry::Pose2;

floor::FloorGraph floorGraphFromLasers(const std::vector<io::CarmenLaser>& lasers,
                                       const LogFloorOptions& o) {
  floor::FloorGraph g;
  g.graph_id = o.graph_id;
  g.floor_id = o.floor_id;
  g.floor_height = o.floor_height;
  // The graph's odometry starts afresh at its first node, so no robot's floor change links
  // it to another graph (floor::transitLinks): each is a robot of its own.
  g.robot = "log_graph_" + std::to_string(o.graph_id);
  std::mt19937_64 rng(o.seed);
  std::normal_distribution<double> n01(0.0, 1.0);
  const Pose2 inverse = o.frame.inverse();
  const std::size_t end = std::min(o.last, lasers.size());
  std::optional<Pose2> previous;
  Pose2 odometry;
  for (std::size_t i = o.first; i < end; ++i) {
    const io::CarmenLaser& laser = lasers[i];
    if (!laser.has_pose || laser.scan.validate() != "") continue;
    const Pose2 pose = laser.robotPose();
    if (previous) {
      const Pose2 delta = previous->between(pose);
      if (delta.translation().norm() < o.node_distance && std::abs(delta.theta()) < o.node_angle)
        continue;
      const double d = delta.translation().norm();
      const Pose2 noisy(delta.x() + o.odometry_translation_sigma * d * n01(rng),
                        delta.y() + o.odometry_translation_sigma * d * n01(rng),
                        delta.theta() + (o.odometry_rotation_sigma * std::abs(delta.theta()) +
                                         o.odometry_rotation_per_metre * d) *
                                            n01(rng));
      odometry = odometry * noisy;
    }
    floor::FloorNode node;
    node.id = static_cast<int>(g.nodes.size());
    node.stamp = laser.scan.stamp;
    node.pose = inverse * pose;
    node.odometry = odometry;
    node.first_pose = odometry;  // no front end here: odometry is the first estimate
    node.scan = laser.scan;
    g.nodes.push_back(std::move(node));
    previous = pose;
  }
  for (std::size_t i = 1; i < g.nodes.size(); ++i) {
    floor::FloorEdge e;
    e.from = g.nodes[i - 1].id;
    e.to = g.nodes[i].id;
    e.measurement = g.nodes[i - 1].pose.between(g.nodes[i].pose);
    g.edges.push_back(e);
  }
  return g;
}

}  // namespace storey::eval
