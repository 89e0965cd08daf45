#include "storey/graph_server/conversions.h"

#include <array>
#include <cmath>
#include <stdexcept>

#include "storey/runtime/graph_conversions.h"
#include "storey/runtime/sensor_conversions.h"

namespace storey::graph_server {
using runtime::requireFinite;

using runtime::informationFromMessage;
using runtime::informationToMessage;

building::FloorGraphDelta fromMessage(const storey_msgs::msg::FloorGraphUpdate& m) {
  building::FloorGraphDelta d;
  d.robot = m.robot();
  d.graph_id = static_cast<int>(m.floor_graph_id());
  d.floor_id = m.floor_id();
  d.floor_height = m.floor_height();
  d.sequence = m.sequence_number();
  const std::string where = "floor graph " + std::to_string(d.graph_id) + " update " + std::to_string(d.sequence);
  requireFinite(d.floor_height, where + ": floor_height");
  for (const auto& n : m.new_nodes()) d.new_nodes.push_back(runtime::fromMessage(n, where));
  for (const auto& e : m.new_edges()) {
    floor::FloorEdge edge;
    edge.from = static_cast<int>(e.from_node());
    edge.to = static_cast<int>(e.to_node());
    const std::string at = where + ": edge " + std::to_string(edge.from) + "->" + std::to_string(edge.to);
    requireFinite(e.dx(), at + ".dx");
    requireFinite(e.dy(), at + ".dy");
    requireFinite(e.dtheta(), at + ".dtheta");
    edge.measurement = geometry::Pose2(e.dx(), e.dy(), e.dtheta());
    edge.information = informationFromMessage(e.information());
    if (e.kind() > 2) throw std::invalid_argument(at + ": unknown edge kind " + std::to_string(e.kind()));
    edge.kind = static_cast<floor::EdgeKind>(e.kind());
    d.new_edges.push_back(edge);
  }
  for (const auto& p : m.optimized_poses()) {
    if (!std::isfinite(p.x()) || !std::isfinite(p.y()) || !std::isfinite(p.theta()))
      throw std::invalid_argument(where + ": optimised pose of node " + std::to_string(p.node_id()) + " is not finite");
    d.poses[static_cast<int>(p.node_id())] = geometry::Pose2(p.x(), p.y(), p.theta());
  }
  return d;
}

building::InterGraphConstraint fromMessage(const storey_msgs::msg::InterFloorConstraint& m) {
  building::InterGraphConstraint c;
  c.id = static_cast<int>(m.constraint_id());
  c.graph_from = static_cast<int>(m.from_floor_graph());
  c.node_from = static_cast<int>(m.from_node());
  c.graph_to = static_cast<int>(m.to_floor_graph());
  c.node_to = static_cast<int>(m.to_node());
  c.relative = geometry::Pose2(m.dx(), m.dy(), m.dtheta());
  c.dz = m.dz();
  c.information = informationFromMessage(m.information());
  return c;
}

building::ConstraintRetraction retractionFromMessage(const storey_msgs::msg::InterFloorConstraint& m) {
  building::ConstraintRetraction r;
  r.graph_from = static_cast<int>(m.from_floor_graph());
  r.node_from = static_cast<int>(m.from_node());
  r.graph_to = static_cast<int>(m.to_floor_graph());
  r.node_to = static_cast<int>(m.to_node());
  r.reason = m.reason();
  return r;
}

storey_msgs::msg::BuildingState toMessage(const building::BuildingSolution& solution,
                                          const std::vector<building::InterGraphConstraint>& constraints,
                                          std::uint32_t sequence, double stamp) {
  storey_msgs::msg::BuildingState state;
  state.sequence_number(sequence);
  state.stamp(runtime::toTimeMessage(stamp));
  state.chi2(solution.final_chi2);
  for (const auto& p : solution.placements) {
    storey_msgs::msg::FloorTransform t;
    t.floor_id(p.floor_id);
    t.x(p.transform.x());
    t.y(p.transform.y());
    t.theta(p.transform.theta());
    t.height(p.height);
    state.floors().push_back(t);
  }
  for (const auto& [key, pose] : solution.poses) {
    storey_msgs::msg::NodePose n;
    n.floor_graph_id(static_cast<std::uint32_t>(key.first));
    n.node_id(static_cast<std::uint32_t>(key.second));
    n.x(pose.x());
    n.y(pose.y());
    n.theta(pose.theta());
    state.node_poses().push_back(n);
  }
  for (const auto& c : constraints) {
    storey_msgs::msg::InterFloorConstraint m;
    m.constraint_id(static_cast<std::uint32_t>(c.id));
    m.from_floor_graph(static_cast<std::uint32_t>(c.graph_from));
    m.from_node(static_cast<std::uint32_t>(c.node_from));
    m.to_floor_graph(static_cast<std::uint32_t>(c.graph_to));
    m.to_node(static_cast<std::uint32_t>(c.node_to));
    m.dx(c.relative.x());
    m.dy(c.relative.y());
    m.dtheta(c.relative.theta());
    m.dz(c.dz);
    m.information(informationToMessage(c.information));
    state.constraints().push_back(m);
  }
  return state;
}

nav_msgs::msg::OccupancyGrid toMessage(const building::FloorMap& floor, double stamp) {
  nav_msgs::msg::OccupancyGrid msg;
  const grid::GridFrame& f = floor.grid.frame();
  msg.header().stamp(runtime::toTimeMessage(stamp));
  msg.header().frame_id("building");
  msg.info().map_load_time(runtime::toTimeMessage(stamp));
  msg.info().resolution(static_cast<float>(f.resolution));
  msg.info().width(static_cast<std::uint32_t>(f.width));
  msg.info().height(static_cast<std::uint32_t>(f.height));
  msg.info().origin().position().x(f.origin_x);
  msg.info().origin().position().y(f.origin_y);
  msg.info().origin().position().z(floor.height);
  msg.info().origin().orientation().w(1.0);
  msg.data().resize(f.cellCount());
  // Trinary, as nav2's map_server publishes a trinary map: 100 occupied, 0 free, -1
  // unknown. The classification (and its thresholds) is the PGM files' (renderGrey), so
  // the live map equals the saved one served by map_server.
  for (int cy = 0; cy < f.height; ++cy)
    for (int cx = 0; cx < f.width; ++cx) {
      std::int8_t value = -1;
      switch (floor.grid.stateAt(cx, cy)) {
        case grid::CellState::kOccupied:
          value = 100;
          break;
        case grid::CellState::kFree:
          value = 0;
          break;
        case grid::CellState::kUnknown:
          value = -1;
          break;
      }
      msg.data()[f.index(cx, cy)] = value;
    }
  return msg;
}

visualization_msgs::msg::MarkerArray toMessage(const std::vector<building::BuildingMarker>& markers,
                                               double stamp) {
  namespace k = visualization_msgs::msg::Marker_Constants;
  visualization_msgs::msg::MarkerArray array;
  std_msgs::msg::Header header;
  header.stamp(runtime::toTimeMessage(stamp));
  header.frame_id("building");
  visualization_msgs::msg::Marker clear;
  clear.header(header);
  clear.action(k::DELETEALL);
  clear.pose().orientation().w(1.0);
  array.markers().push_back(clear);
  for (const auto& m : markers) {
    visualization_msgs::msg::Marker out;
    out.header(header);
    out.ns(m.ns);
    out.id(m.id);
    out.action(k::ADD);
    out.pose().orientation().w(1.0);
    out.color().r(m.rgba[0]);
    out.color().g(m.rgba[1]);
    out.color().b(m.rgba[2]);
    out.color().a(m.rgba[3]);
    switch (m.kind) {
      case building::BuildingMarker::Kind::kLineStrip:
      case building::BuildingMarker::Kind::kLineList:
        out.type(m.kind == building::BuildingMarker::Kind::kLineStrip ? k::LINE_STRIP
                                                                      : k::LINE_LIST);
        out.scale().x(0.05);  // line width, m
        for (const auto& p : m.points) {
          geometry_msgs::msg::Point point;
          point.x(p.x());
          point.y(p.y());
          point.z(p.z());
          out.points().push_back(point);
        }
        break;
      case building::BuildingMarker::Kind::kText:
        out.type(k::TEXT_VIEW_FACING);
        out.scale().z(0.5);  // text height, m
        out.text(m.text);
        if (!m.points.empty()) {
          out.pose().position().x(m.points.front().x());
          out.pose().position().y(m.points.front().y());
          out.pose().position().z(m.points.front().z() + 1.0);  // above the floor's first node
        }
        break;
    }
    array.markers().push_back(out);
  }
  return array;
}

}  // namespace storey::graph_server
