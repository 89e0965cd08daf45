// storey_msgs floor-graph messages <-> core floor graph types, shared by every component
// that sends floor graphs (floor_mapper, the fleet benchmark) or receives them
// (floor_matcher, graph_server).
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <string>

#include "storey/floor/floor_graph.h"
#include "storey_msgs/msg/FloorGraphEdge.h"
#include "storey_msgs/msg/FloorGraphNode.h"

namespace storey::runtime {

// Throws std::invalid_argument for a value that cannot be accepted (a non-finite pose,
// height or sensor mounting, a scan with bad limits): `where` and the field lead the
// message. The message carries no raw odometry: the node's odometry is its pose.
floor::FloorNode fromMessage(const storey_msgs::msg::FloorGraphNode& message, const std::string& where);
void requireFinite(double value, const std::string& field);

// A node (pose, stamp, scan and its mounting) of floor graph `graph_id` as a message.
storey_msgs::msg::FloorGraphNode toMessage(const floor::FloorNode& node, std::uint32_t graph_id);
// An edge (measurement, information, kind) as a message.
storey_msgs::msg::FloorGraphEdge toMessage(const floor::FloorEdge& edge);

// A 3x3 information matrix over (dx, dy, dθ) as the messages carry it: row-major, 9 values.
std::array<double, 9> informationToMessage(const Eigen::Matrix3d& information);
Eigen::Matrix3d informationFromMessage(const std::array<double, 9>& values);

}  // namespace storey::runtime
