// The graph server's journal record decoder (storey::building decodeRecord): raw bytes,
// or a valid encoded delta/constraint/retraction patched by the input (fuzz_support.h).
#include <cstdint>
#include <stdexcept>
#include <vector>

#include "fuzz_support.h"
#include "storey/building/journal.h"

namespace {

std::vector<std::uint8_t> sampleRecord(int kind) {
  using namespace storey;
  if (kind == 2) {
    building::ConstraintRetraction r;
    r.graph_from = 1;
    r.node_from = 4;
    r.graph_to = 2;
    r.node_to = 7;
    r.reason = "placed 3 m away";
    return building::encodeRecord(building::JournalRecord(r));
  }
  if (kind == 1) {
    building::InterGraphConstraint c;
    c.id = 3;
    c.graph_from = 1;
    c.node_from = 4;
    c.graph_to = 2;
    c.node_to = 7;
    c.relative = geometry::Pose2(1.0, -2.0, 0.3);
    c.dz = 3.1;
    return building::encodeRecord(building::JournalRecord(c));
  }
  building::FloorGraphDelta delta;
  delta.robot = "robot1";
  delta.graph_id = 1;
  delta.floor_id = 2;
  delta.floor_height = 3.0;
  delta.sequence = 5;
  for (int i = 0; i < 2; ++i) {
    floor::FloorNode node;
    node.id = i;
    node.stamp = 10.0 + i;
    node.pose = geometry::Pose2(i, 0.5, 0.1);
    node.scan.angle_min = -1.5f;
    node.scan.angle_increment = 0.5f;
    node.scan.range_max = 30.0f;
    node.scan.ranges = {1.0f, 2.0f, 3.0f, 4.0f, 5.0f, 6.0f, 7.0f};
    delta.new_nodes.push_back(node);
    delta.poses[i] = node.pose;
  }
  floor::FloorEdge edge;
  edge.from = 0;
  edge.to = 1;
  edge.measurement = geometry::Pose2(1.0, 0.0, 0.0);
  delta.new_edges.push_back(edge);
  return building::encodeRecord(building::JournalRecord(delta));
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const std::vector<std::uint8_t> samples[3] = {sampleRecord(0), sampleRecord(1), sampleRecord(2)};
  std::vector<std::uint8_t> bytes;
  if (size > 0 && (data[0] & 1)) {
    bytes = storey::fuzz::patchSample(samples[(data[0] >> 1) % 3], data + 1, size - 1);
  } else {
    bytes.assign(data, data + size);
  }
  try {
    (void)storey::building::decodeRecord(bytes.data(), bytes.size());
  } catch (const std::runtime_error&) {
  }
  return 0;
}
