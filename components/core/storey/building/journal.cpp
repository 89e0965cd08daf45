#include "storey/building/journal.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <iterator>
#include <ostream>
#include <set>
#include <sstream>
#include <stdexcept>

#include "storey/common/file_checks.h"
#include "storey/common/log.h"
#include "storey/common/record_file.h"

namespace storey::building {
namespace {

constexpr char kFileMagic[8] = {'S', 'T', 'O', 'R', 'E', 'Y', 'J', '1'};
enum RecordType : std::uint8_t { kDelta = 1, kConstraint = 2, kRetraction = 3 };

class Encoder : public common::ByteEncoder {
 public:
  void putPose(const geometry::Pose2& p) {
    put(p.x());
    put(p.y());
    put(p.theta());
  }
  void putMatrix(const Eigen::Matrix3d& m) {
    for (int i = 0; i < 9; ++i) put(m.data()[i]);
  }
};

class Decoder : public common::ByteDecoder {
 public:
  using common::ByteDecoder::ByteDecoder;
  geometry::Pose2 getPose() {
    const double x = get<double>(), y = get<double>(), t = get<double>();
    return geometry::Pose2(x, y, t);
  }
  Eigen::Matrix3d getMatrix() {
    Eigen::Matrix3d m;
    for (int i = 0; i < 9; ++i) m.data()[i] = get<double>();
    return m;
  }
};

}  // namespace

std::vector<std::uint8_t> encodeRecord(const JournalRecord& record) {
  Encoder e;
  if (const auto* d = std::get_if<FloorGraphDelta>(&record)) {
    e.put<std::uint8_t>(kDelta);
    e.putString(d->robot);
    e.put<std::int32_t>(d->graph_id);
    e.put<std::int32_t>(d->floor_id);
    e.put(d->floor_height);
    e.put(d->sequence);
    e.put<std::uint32_t>(static_cast<std::uint32_t>(d->new_nodes.size()));
    for (const auto& n : d->new_nodes) {
      e.put<std::int32_t>(n.id);
      e.put(n.stamp);
      e.putPose(n.pose);
      e.putPose(n.odometry);
      e.put(n.scan.stamp);
      e.put(n.scan.angle_min);
      e.put(n.scan.angle_increment);
      e.put(n.scan.range_min);
      e.put(n.scan.range_max);
      e.putPose(n.scan.sensor_offset);
      e.put<std::uint32_t>(static_cast<std::uint32_t>(n.scan.ranges.size()));
      for (float r : n.scan.ranges) e.put(r);
    }
    e.put<std::uint32_t>(static_cast<std::uint32_t>(d->new_edges.size()));
    for (const auto& edge : d->new_edges) {
      e.put<std::int32_t>(edge.from);
      e.put<std::int32_t>(edge.to);
      e.putPose(edge.measurement);
      e.putMatrix(edge.information);
      e.put<std::uint8_t>(static_cast<std::uint8_t>(edge.kind));
    }
    e.put<std::uint32_t>(static_cast<std::uint32_t>(d->poses.size()));
    for (const auto& [id, pose] : d->poses) {
      e.put<std::int32_t>(id);
      e.putPose(pose);
    }
  } else if (const auto* r = std::get_if<ConstraintRetraction>(&record)) {
    e.put<std::uint8_t>(kRetraction);
    e.put<std::int32_t>(r->graph_from);
    e.put<std::int32_t>(r->node_from);
    e.put<std::int32_t>(r->graph_to);
    e.put<std::int32_t>(r->node_to);
    e.putString(r->reason);
  } else {
    const auto& c = std::get<InterGraphConstraint>(record);
    e.put<std::uint8_t>(kConstraint);
    e.put<std::int32_t>(c.id);
    e.put<std::int32_t>(c.graph_from);
    e.put<std::int32_t>(c.node_from);
    e.put<std::int32_t>(c.graph_to);
    e.put<std::int32_t>(c.node_to);
    e.putPose(c.relative);
    e.put(c.dz);
    e.putMatrix(c.information);
  }
  return e.bytes;
}

JournalRecord decodeRecord(const std::uint8_t* data, std::size_t size) {
  Decoder d(data, size);
  const auto type = d.get<std::uint8_t>();
  if (type == kDelta) {
    FloorGraphDelta delta;
    delta.robot = d.getString();
    delta.graph_id = d.get<std::int32_t>();
    delta.floor_id = d.get<std::int32_t>();
    delta.floor_height = d.get<double>();
    delta.sequence = d.get<std::uint32_t>();
    const auto nodes = d.getCount(100);
    for (std::uint32_t i = 0; i < nodes; ++i) {
      floor::FloorNode n;
      n.id = d.get<std::int32_t>();
      n.stamp = d.get<double>();
      n.pose = d.getPose();
      n.odometry = d.getPose();
      n.first_pose = n.pose;  // a delta's new nodes have the pose they were first given
      n.scan.stamp = d.get<double>();
      n.scan.angle_min = d.get<double>();
      n.scan.angle_increment = d.get<double>();
      n.scan.range_min = d.get<double>();
      n.scan.range_max = d.get<double>();
      n.scan.sensor_offset = d.getPose();
      const auto beams = d.getCount(sizeof(float));
      n.scan.ranges.resize(beams);
      for (auto& r : n.scan.ranges) r = d.get<float>();
      delta.new_nodes.push_back(std::move(n));
    }
    const auto edges = d.getCount(8 + 24 + 72 + 1);
    for (std::uint32_t i = 0; i < edges; ++i) {
      floor::FloorEdge edge;
      edge.from = d.get<std::int32_t>();
      edge.to = d.get<std::int32_t>();
      edge.measurement = d.getPose();
      edge.information = d.getMatrix();
      const auto kind = d.get<std::uint8_t>();
      if (kind > static_cast<std::uint8_t>(floor::EdgeKind::kLoopClosure))
        throw std::runtime_error("unknown edge kind " + std::to_string(kind));
      edge.kind = static_cast<floor::EdgeKind>(kind);
      delta.new_edges.push_back(edge);
    }
    const auto poses = d.getCount(4 + 24);
    for (std::uint32_t i = 0; i < poses; ++i) {
      const int id = d.get<std::int32_t>();
      delta.poses[id] = d.getPose();
    }
    if (!d.done()) throw std::runtime_error("trailing bytes in a floor-graph record");
    return delta;
  }
  if (type == kConstraint) {
    InterGraphConstraint c;
    c.id = d.get<std::int32_t>();
    c.graph_from = d.get<std::int32_t>();
    c.node_from = d.get<std::int32_t>();
    c.graph_to = d.get<std::int32_t>();
    c.node_to = d.get<std::int32_t>();
    c.relative = d.getPose();
    c.dz = d.get<double>();
    c.information = d.getMatrix();
    if (!d.done()) throw std::runtime_error("trailing bytes in a constraint record");
    return c;
  }
  if (type == kRetraction) {
    ConstraintRetraction r;
    r.graph_from = d.get<std::int32_t>();
    r.node_from = d.get<std::int32_t>();
    r.graph_to = d.get<std::int32_t>();
    r.node_to = d.get<std::int32_t>();
    r.reason = d.getString();
    if (!d.done()) throw std::runtime_error("trailing bytes in a retraction record");
    return r;
  }
  throw std::runtime_error("unknown record type " + std::to_string(type));
}

void checkDelta(const BuildingGraph& building, const FloorGraphDelta& delta) {
  auto fail = [&](const std::string& why) {
    throw std::invalid_argument("floor graph " + std::to_string(delta.graph_id) + " (robot " +
                                delta.robot + "): " + why);
  };
  if (!(std::abs(delta.floor_height) <= kMaxFloorHeight)) {
    std::ostringstream out;
    out << "floor height " << delta.floor_height << " m is not within +-" << kMaxFloorHeight
        << " m";
    fail(out.str());
  }
  for (const auto& node : delta.new_nodes)
    if (!node.pose.isFinite() || !node.odometry.isFinite() || !std::isfinite(node.stamp))
      fail("node " + std::to_string(node.id) + " has a non-finite pose, odometry or stamp");
  for (const auto& [id, pose] : delta.poses)
    if (!pose.isFinite()) fail("node " + std::to_string(id) + " is given a non-finite pose");
  for (const auto& edge : delta.new_edges)
    if (!edge.measurement.isFinite() || !edge.information.allFinite())
      fail("edge " + std::to_string(edge.from) + " -> " + std::to_string(edge.to) +
           " has non-finite values");
  auto existing = building.floorGraphs().find(delta.graph_id);
  if (existing != building.floorGraphs().end()) floor::requireSameRobot(existing->second, delta.robot);
  std::set<int> known;
  if (existing != building.floorGraphs().end())
    for (const auto& node : existing->second.nodes) known.insert(node.id);
  for (const auto& node : delta.new_nodes) known.insert(node.id);
  for (const auto& edge : delta.new_edges) {
    if (!known.count(edge.from) || !known.count(edge.to)) {
      std::ostringstream out;
      out << "floor graph " << delta.graph_id << " (robot " << delta.robot << "): edge " << edge.from << " -> "
          << edge.to << " refers to an unknown node";
      throw std::invalid_argument(out.str());
    }
  }
}

JournalBuilding rebuildFromJournal(const std::string& path) {
  JournalReadResult journal = readJournal(path);
  JournalBuilding out;
  out.records = journal.records.size();
  out.torn_tail = journal.torn_tail;
  for (std::size_t i = 0; i < journal.records.size(); ++i) {
    try {
      applyRecord(out.graph, journal.records[i]);
    } catch (const std::exception& e) {
      out.skipped.push_back("record " + std::to_string(i + 1) + ": " + e.what());
    }
  }
  return out;
}

std::vector<std::string> journalProblems(const std::string& path, const JournalBuilding& journal) {
  std::vector<std::string> problems;
  if (journal.torn_tail) problems.push_back(path + ": the last record was torn and is ignored");
  for (const auto& why : journal.skipped) {
    std::string line = path;
    line.append(": ").append(why).append(" (skipped)");
    problems.push_back(std::move(line));
  }
  return problems;
}

void printJournalProblems(std::ostream& out, const std::string& path, const JournalBuilding& journal) {
  for (const std::string& problem : journalProblems(path, journal)) out << problem << "\n";
}

void applyRecord(BuildingGraph& building, const JournalRecord& record) {
  if (const auto* d = std::get_if<FloorGraphDelta>(&record)) applyDelta(building, *d);
  else if (const auto* c = std::get_if<InterGraphConstraint>(&record)) building.addConstraint(*c);
  else building.retractConstraint(std::get<ConstraintRetraction>(record));
}

void applyDelta(BuildingGraph& building, const FloorGraphDelta& delta) {
  checkDelta(building, delta);  // a rejected delta changes nothing
  floor::FloorGraph& graph = building.floorGraphForUpdate(delta.graph_id);
  graph.robot = delta.robot;
  graph.floor_id = delta.floor_id;
  graph.floor_height = delta.floor_height;
  std::set<int> present;
  for (const auto& node : graph.nodes) present.insert(node.id);
  for (const auto& node : delta.new_nodes)
    if (present.insert(node.id).second) graph.nodes.push_back(node);
  for (const auto& edge : delta.new_edges) {
    const bool duplicate = std::any_of(graph.edges.begin(), graph.edges.end(), [&](const floor::FloorEdge& e) {
      return e.from == edge.from && e.to == edge.to && e.kind == edge.kind;
    });
    if (!duplicate) graph.edges.push_back(edge);
  }
  if (!delta.poses.empty())
    for (auto& node : graph.nodes) {
      auto pose = delta.poses.find(node.id);
      if (pose != delta.poses.end()) node.pose = pose->second;
    }
}

JournalReadResult readJournal(const std::string& path) {
  JournalReadResult result;
  const common::RecordFileReadResult read =
      common::readRecordFile(path, kFileMagic, "journal", [&](const std::uint8_t* payload, std::size_t size) {
        result.records.push_back(decodeRecord(payload, size));
      });
  result.torn_tail = read.torn_tail;
  result.valid_bytes = read.valid_bytes;
  return result;
}

JournalCheck checkJournal(const std::string& path) {
  JournalCheck check;
  BuildingGraph building;
  std::set<std::pair<int, std::uint32_t>> updates;
  std::set<std::string> robots;
  check.scan = common::scanRecordFile(
      path, kFileMagic, "journal", [&](const std::uint8_t* payload, std::size_t size) {
        const JournalRecord record = decodeRecord(payload, size);
        if (const auto* d = std::get_if<FloorGraphDelta>(&record)) {
          ++check.deltas;
          robots.insert(d->robot);
          if (!updates.insert({d->graph_id, d->sequence}).second) ++check.repeated_updates;
        } else if (std::holds_alternative<InterGraphConstraint>(record)) {
          ++check.constraints;
        } else {
          ++check.retractions;
        }
        try {
          applyRecord(building, record);
        } catch (const std::exception& e) {
          check.skipped.push_back(
              "record " + std::to_string(check.deltas + check.constraints + check.retractions) +
              ": " + e.what());
        }
      });
  check.floor_graphs = building.floorGraphs().size();
  for (const auto& [id, graph] : building.floorGraphs()) check.nodes += graph.nodes.size();
  check.robots.assign(robots.begin(), robots.end());
  return check;
}

void printJournalCheck(std::ostream& out, const std::string& path, const JournalCheck& check) {
  const auto& scan = check.scan;
  out << path << ": storey journal, " << common::byteCount(scan.file_bytes) << "\n";
  out << "  intact: " << scan.records << " records in the first " << scan.valid_bytes << " bytes ("
      << check.deltas << " floor-graph updates, " << check.constraints << " constraints, "
      << check.retractions << " retractions)\n";
  out << "  building: " << check.floor_graphs << " floor graphs, " << check.nodes
      << " nodes, robots:";
  for (const auto& robot : check.robots) out << " " << robot;
  out << "\n";
  if (check.repeated_updates)
    out << "  " << check.repeated_updates << " floor-graph updates journalled more than once\n";
  for (const auto& why : check.skipped) out << "  " << why << " (not applied)\n";
  switch (scan.end) {
    case common::RecordFileEnd::kIntact:
      out << "  end: intact\n";
      break;
    case common::RecordFileEnd::kTornTail:
      out << "  end: torn last record at offset " << scan.valid_bytes << " (" << scan.problem
          << ", " << scan.file_bytes - scan.valid_bytes
          << " bytes): a graph server drops it when it opens the journal\n";
      break;
    case common::RecordFileEnd::kDamaged:
      out << "  end: " << common::describeDamage(path, "journal", scan) << "\n";
      break;
  }
}

common::RecordFileScan salvageJournal(const std::string& in, const std::string& out) {
  return common::salvageRecordFile(
      in, out, kFileMagic, "journal",
      [](const std::uint8_t* payload, std::size_t size) { (void)decodeRecord(payload, size); });
}

bool looksLikeJournal(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  char head[sizeof kFileMagic] = {};
  return in.read(head, sizeof head) && std::memcmp(head, kFileMagic, sizeof head) == 0;
}

JournalWriter::JournalWriter(const std::string& path, bool sync)
    : file_(path, kFileMagic, "journal",
            [this](const std::uint8_t* payload, std::size_t size) {
              existing_.push_back(decodeRecord(payload, size));
            }),
      sync_(sync) {}

void JournalWriter::append(const JournalRecord& record) { file_.append(encodeRecord(record)); }

}  // namespace storey::building
