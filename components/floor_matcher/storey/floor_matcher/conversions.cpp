#include "storey/floor_matcher/conversions.h"

#include <cmath>
#include <stdexcept>
#include <string>

#include "storey/runtime/graph_conversions.h"
#include "storey/runtime/sensor_conversions.h"

namespace storey::floor_matcher {
using runtime::requireFinite;

void applyUpdate(const storey_msgs::msg::FloorGraphUpdate& m,
                 std::map<int, floor::FloorGraph>* graphs) {
  const int id = static_cast<int>(m.floor_graph_id());
  const std::string where =
      "floor graph " + std::to_string(id) + " update " + std::to_string(m.sequence_number());
  requireFinite(m.floor_height(), where + ": floor_height");
  floor::FloorGraph g = graphs->count(id) ? graphs->at(id) : floor::FloorGraph{};
  if (graphs->count(id)) floor::requireSameRobot(g, m.robot());
  g.robot = m.robot();
  g.graph_id = id;
  g.floor_id = m.floor_id();
  g.floor_height = m.floor_height();
  for (const auto& n : m.new_nodes()) {
    floor::FloorNode node = runtime::fromMessage(n, where);
    if (g.findNode(node.id)) continue;
    g.nodes.push_back(std::move(node));
  }
  for (const auto& e : m.new_edges()) {
    floor::FloorEdge edge;
    edge.from = static_cast<int>(e.from_node());
    edge.to = static_cast<int>(e.to_node());
    const std::string at =
        where + ": edge " + std::to_string(edge.from) + "->" + std::to_string(edge.to);
    requireFinite(e.dx(), at + ".dx");
    requireFinite(e.dy(), at + ".dy");
    requireFinite(e.dtheta(), at + ".dtheta");
    edge.measurement = geometry::Pose2(e.dx(), e.dy(), e.dtheta());
    g.edges.push_back(edge);
  }
  for (const auto& p : m.optimized_poses()) {
    const std::string at = where + ": optimised pose of node " + std::to_string(p.node_id());
    requireFinite(p.x(), at + ".x");
    requireFinite(p.y(), at + ".y");
    requireFinite(p.theta(), at + ".theta");
    bool found = false;
    for (auto& node : g.nodes) {
      if (node.id != static_cast<int>(p.node_id())) continue;
      node.pose = geometry::Pose2(p.x(), p.y(), p.theta());
      found = true;
    }
    if (!found) throw std::invalid_argument(at + ": unknown node");
  }
  (*graphs)[id] = std::move(g);
}

storey_msgs::msg::InterFloorConstraint toMessage(const matching::InterFloorConstraint& c,
                                                 std::uint32_t id, double l_min,
                                                 std::uint32_t support) {
  storey_msgs::msg::InterFloorConstraint m;
  m.constraint_id(id);
  m.from_floor_graph(static_cast<std::uint32_t>(c.reference_graph_id));
  m.from_node(static_cast<std::uint32_t>(c.reference_node_id));
  m.to_floor_graph(static_cast<std::uint32_t>(c.graph_id));
  m.to_node(static_cast<std::uint32_t>(c.node_id));
  m.dx(c.measurement.x());
  m.dy(c.measurement.y());
  m.dtheta(c.measurement.theta());
  m.dz(c.dz);
  m.information(runtime::informationToMessage(c.information));
  m.dz_variance(0.01);  // floor heights come from the detector; 0.1 m standard deviation
  m.mean_likelihood(c.likelihood);
  m.likelihood_threshold(l_min);
  m.scans_used(static_cast<std::uint32_t>(c.last_index - c.first_index + 1));
  m.ransac_support(support);
  return m;
}

matching::InterFloorConstraint constraintFromMessage(const storey_msgs::msg::InterFloorConstraint& m) {
  matching::InterFloorConstraint c;
  c.reference_graph_id = static_cast<int>(m.from_floor_graph());
  c.reference_node_id = static_cast<int>(m.from_node());
  c.graph_id = static_cast<int>(m.to_floor_graph());
  c.node_id = static_cast<int>(m.to_node());
  c.measurement = geometry::Pose2(m.dx(), m.dy(), m.dtheta());
  c.dz = m.dz();
  c.information = runtime::informationFromMessage(m.information());
  return c;
}

}  // namespace storey::floor_matcher
