#include "storey/building/journal.h"

#include <unistd.h>
#include <zlib.h>

#include <algorithm>
#include <cstring>
#include <fstream>
#include <iterator>
#include <set>
#include <sstream>
#include <stdexcept>

#include "storey/common/log.h"

namespace storey::building {
namespace {

constexpr char kFileMagic[8] = {'S', 'T', 'O', 'R', 'E', 'Y', 'J', '1'};
constexpr std::uint32_t kRecordMagic = 0x4A524543;  // "JREC"
constexpr std::size_t kFrameHeader = 8;            // magic + payload length
constexpr std::size_t kFrameTrailer = 4;           // crc32 of the payload
constexpr std::uint32_t kMaxPayload = 1u << 30;
enum RecordType : std::uint8_t { kDelta = 1, kConstraint = 2 };

class Encoder {
 public:
  template <typename T>
  void put(T value) {
    static_assert(std::is_trivially_copyable_v<T>);
    const auto* p = reinterpret_cast<const std::uint8_t*>(&value);
    bytes.insert(bytes.end(), p, p + sizeof(T));
  }
  void putString(const std::string& s) {
    put<std::uint32_t>(static_cast<std::uint32_t>(s.size()));
    bytes.insert(bytes.end(), s.begin(), s.end());
  }
  void putPose(const geometry::Pose2& p) {
    put(p.x());
    put(p.y());
    put(p.theta());
  }
  void putMatrix(const Eigen::Matrix3d& m) {
    for (int i = 0; i < 9; ++i) put(m.data()[i]);
  }
  std::vector<std::uint8_t> bytes;
};

class Decoder {
 public:
  Decoder(const std::uint8_t* data, std::size_t size) : data_(data), size_(size) {}
  template <typename T>
  T get() {
    if (pos_ + sizeof(T) > size_) throw std::runtime_error("record ends early");
    T value;
    std::memcpy(&value, data_ + pos_, sizeof(T));
    pos_ += sizeof(T);
    return value;
  }
  std::string getString() {
    const auto n = get<std::uint32_t>();
    if (pos_ + n > size_) throw std::runtime_error("string runs past the record");
    std::string s(reinterpret_cast<const char*>(data_ + pos_), n);
    pos_ += n;
    return s;
  }
  geometry::Pose2 getPose() {
    const double x = get<double>(), y = get<double>(), t = get<double>();
    return geometry::Pose2(x, y, t);
  }
  Eigen::Matrix3d getMatrix() {
    Eigen::Matrix3d m;
    for (int i = 0; i < 9; ++i) m.data()[i] = get<double>();
    return m;
  }
  // A count of items of at least `min_item_bytes` each must fit in what is left.
  std::uint32_t getCount(std::size_t min_item_bytes) {
    const auto n = get<std::uint32_t>();
    if (static_cast<std::uint64_t>(n) * min_item_bytes > size_ - pos_)
      throw std::runtime_error("count larger than the record");
    return n;
  }
  bool done() const { return pos_ == size_; }

 private:
  const std::uint8_t* data_;
  std::size_t size_;
  std::size_t pos_ = 0;
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
  throw std::runtime_error("unknown record type " + std::to_string(type));
}

void checkDelta(const BuildingGraph& building, const FloorGraphDelta& delta) {
  auto existing = building.floorGraphs().find(delta.graph_id);
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
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error(path + ": cannot open the journal");
  std::vector<std::uint8_t> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  JournalReadResult result;
  if (bytes.empty()) return result;
  if (bytes.size() < sizeof(kFileMagic) || std::memcmp(bytes.data(), kFileMagic, sizeof(kFileMagic)) != 0) {
    if (bytes.size() < sizeof(kFileMagic) &&
        std::memcmp(bytes.data(), kFileMagic, bytes.size()) == 0) {  // torn while creating
      result.torn_tail = true;
      return result;
    }
    throw std::runtime_error(path + ": not a storey journal");
  }
  std::size_t pos = sizeof(kFileMagic);
  result.valid_bytes = pos;
  while (pos < bytes.size()) {
    const std::size_t left = bytes.size() - pos;
    auto torn = [&](const std::string& why) {
      common::logWarn(common::str(path, ": dropping a torn last record at offset ", pos, " (", why, ")"));
      result.torn_tail = true;
    };
    if (left < kFrameHeader) {
      torn("short header");
      break;
    }
    std::uint32_t magic, length;
    std::memcpy(&magic, &bytes[pos], 4);
    std::memcpy(&length, &bytes[pos + 4], 4);
    if (magic != kRecordMagic || length > kMaxPayload) {
      std::ostringstream out;
      out << path << ": corrupt journal record at offset " << pos;
      throw std::runtime_error(out.str());
    }
    if (left < kFrameHeader + length + kFrameTrailer) {
      torn("short record");
      break;
    }
    const std::uint8_t* payload = &bytes[pos + kFrameHeader];
    std::uint32_t crc;
    std::memcpy(&crc, payload + length, 4);
    const bool last = pos + kFrameHeader + length + kFrameTrailer == bytes.size();
    if (crc != static_cast<std::uint32_t>(crc32(0L, payload, length))) {
      if (last) {
        torn("checksum mismatch");
        break;
      }
      std::ostringstream out;
      out << path << ": journal record at offset " << pos << " fails its checksum";
      throw std::runtime_error(out.str());
    }
    try {
      result.records.push_back(decodeRecord(payload, length));
    } catch (const std::runtime_error& e) {
      std::ostringstream out;
      out << path << ": journal record at offset " << pos << ": " << e.what();
      throw std::runtime_error(out.str());
    }
    pos += kFrameHeader + length + kFrameTrailer;
    result.valid_bytes = pos;
  }
  return result;
}

JournalWriter::JournalWriter(const std::string& path, bool sync) : path_(path), sync_(sync) {
  std::uint64_t valid = 0;
  if (std::ifstream(path).good()) {
    JournalReadResult read = readJournal(path);
    existing_ = std::move(read.records);
    had_torn_tail_ = read.torn_tail;
    valid = read.valid_bytes;
    if (truncate(path.c_str(), static_cast<off_t>(valid)) != 0)
      throw std::runtime_error(path + ": cannot cut off the torn journal tail");
  }
  file_ = std::fopen(path.c_str(), "ab");
  if (!file_) throw std::runtime_error(path + ": cannot open the journal for appending");
  if (valid == 0) {
    std::fwrite(kFileMagic, 1, sizeof(kFileMagic), file_);
    std::fflush(file_);
  }
}

JournalWriter::~JournalWriter() {
  if (file_) std::fclose(file_);
}

void JournalWriter::append(const JournalRecord& record) {
  const std::vector<std::uint8_t> payload = encodeRecord(record);
  const std::uint32_t length = static_cast<std::uint32_t>(payload.size());
  const std::uint32_t crc = static_cast<std::uint32_t>(crc32(0L, payload.data(), length));
  std::vector<std::uint8_t> frame(kFrameHeader + payload.size() + kFrameTrailer);
  std::memcpy(&frame[0], &kRecordMagic, 4);
  std::memcpy(&frame[4], &length, 4);
  std::memcpy(&frame[8], payload.data(), payload.size());
  std::memcpy(&frame[8 + payload.size()], &crc, 4);
  if (std::fwrite(frame.data(), 1, frame.size(), file_) != frame.size() || std::fflush(file_) != 0)
    throw std::runtime_error(path_ + ": journal write failed");
  if (sync_ && fdatasync(fileno(file_)) != 0) throw std::runtime_error(path_ + ": journal sync failed");
}

}  // namespace storey::building
