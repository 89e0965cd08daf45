#include "storey/mapping/input_log.h"

#include <cmath>
#include <cstring>
#include <fstream>
#include <stdexcept>

namespace storey::mapping {
namespace {

constexpr char kFileMagic[8] = {'S', 'T', 'O', 'R', 'E', 'Y', 'M', '1'};
// kFloorEvent: logs written before events carried candidate floors (still read).
enum InputType : std::uint8_t { kScan = 1, kFloorEvent = 2, kFloorEventWithCandidates = 3 };

void putPose(common::ByteEncoder& e, const geometry::Pose2& p) {
  e.put(p.x());
  e.put(p.y());
  e.put(p.theta());
}

geometry::Pose2 getPose(common::ByteDecoder& d) {
  const double x = d.get<double>(), y = d.get<double>(), theta = d.get<double>();
  return geometry::Pose2(x, y, theta);
}

}  // namespace

namespace {
// Encodes a scan record from its parts: the mapper logs every scan, so no copy of it is
// made for logging.
void encodeScan(common::ByteEncoder& e, const sensor::LaserScan& s, const geometry::Pose2& odometry) {
  e.put<std::uint8_t>(kScan);
  e.put(s.stamp);
  e.put(s.angle_min);
  e.put(s.angle_increment);
  e.put(s.range_min);
  e.put(s.range_max);
  putPose(e, s.sensor_offset);
  putPose(e, odometry);
  e.put<std::uint32_t>(static_cast<std::uint32_t>(s.ranges.size()));
  for (float r : s.ranges) e.put(r);
}

void encodeEvent(common::ByteEncoder& e, const floor::FloorEvent& ev) {
  e.put<std::uint8_t>(kFloorEventWithCandidates);
  e.put<std::uint8_t>(static_cast<std::uint8_t>(ev.type));
  e.put(ev.stamp);
  e.put(ev.decided_at);
  e.put<std::int32_t>(ev.floor_id);
  e.put(ev.floor_height);
  e.put<std::uint32_t>(static_cast<std::uint32_t>(ev.candidate_floors.size()));
  for (const int f : ev.candidate_floors) e.put<std::int32_t>(f);
  e.put<std::int32_t>(ev.new_floor_id);
  e.put(ev.new_floor_height);
}
}  // namespace

std::vector<std::uint8_t> encodeLoggedInput(const LoggedInput& input) {
  common::ByteEncoder e;
  if (input.is_scan) encodeScan(e, input.scan, input.odometry);
  else encodeEvent(e, input.event);
  return e.bytes;
}

LoggedInput decodeLoggedInput(const std::uint8_t* data, std::size_t size) {
  common::ByteDecoder d(data, size);
  LoggedInput input;
  const auto type = d.get<std::uint8_t>();
  if (type == kScan) {
    sensor::LaserScan& s = input.scan;
    s.stamp = d.get<double>();
    s.angle_min = d.get<double>();
    s.angle_increment = d.get<double>();
    s.range_min = d.get<double>();
    s.range_max = d.get<double>();
    s.sensor_offset = getPose(d);
    input.odometry = getPose(d);
    s.ranges.resize(d.getCount(sizeof(float)));
    for (auto& r : s.ranges) r = d.get<float>();
    if (!std::isfinite(s.stamp)) throw std::runtime_error("scan with a non-finite stamp");
  } else if (type == kFloorEvent || type == kFloorEventWithCandidates) {
    input.is_scan = false;
    floor::FloorEvent& ev = input.event;
    const auto kind = d.get<std::uint8_t>();
    if (kind > static_cast<std::uint8_t>(floor::FloorEventType::kAwaitingIdentity) ||
        kind == static_cast<std::uint8_t>(floor::FloorEventType::kProgress))
      throw std::runtime_error("unknown floor event type " + std::to_string(kind));
    ev.type = static_cast<floor::FloorEventType>(kind);
    ev.stamp = d.get<double>();
    ev.decided_at = d.get<double>();
    ev.floor_id = d.get<std::int32_t>();
    ev.floor_height = d.get<double>();
    if (!std::isfinite(ev.decided_at) || !std::isfinite(ev.floor_height))
      throw std::runtime_error("floor event with a non-finite stamp or height");
    if (type == kFloorEventWithCandidates) {
      ev.candidate_floors.resize(d.getCount(sizeof(std::int32_t)));
      for (auto& f : ev.candidate_floors) f = d.get<std::int32_t>();
      ev.new_floor_id = d.get<std::int32_t>();
      ev.new_floor_height = d.get<double>();
      if (!std::isfinite(ev.new_floor_height))
        throw std::runtime_error("floor event with a non-finite new floor height");
    }
  } else {
    throw std::runtime_error("unknown input type " + std::to_string(type));
  }
  if (!d.done()) throw std::runtime_error("trailing bytes in an input record");
  return input;
}

InputLog::InputLog(const std::string& path, const std::function<void(const LoggedInput&)>& on_existing) {
  file_ = std::make_unique<common::RecordFileWriter>(
      path, kFileMagic, "input log", [&](const std::uint8_t* payload, std::size_t size) {
        const LoggedInput input = decodeLoggedInput(payload, size);
        if (input.is_scan)
          last_scan_stamp_ = input.scan.stamp;
        else
          last_event_decided_at_ = input.event.decided_at;
        on_existing(input);
      });
}

bool looksLikeInputLog(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  char head[sizeof kFileMagic] = {};
  return in.read(head, sizeof head) && std::memcmp(head, kFileMagic, sizeof head) == 0;
}

common::RecordFileScan scanInputLog(const std::string& path) {
  return common::scanRecordFile(path, kFileMagic, "input log",
                                [](const std::uint8_t* payload, std::size_t size) {
                                  (void)decodeLoggedInput(payload, size);
                                });
}

common::RecordFileScan salvageInputLog(const std::string& in, const std::string& out) {
  return common::salvageRecordFile(in, out, kFileMagic, "input log",
                                   [](const std::uint8_t* payload, std::size_t size) {
                                     (void)decodeLoggedInput(payload, size);
                                   });
}

void InputLog::appendScan(const sensor::LaserScan& scan, const geometry::Pose2& odometry) {
  common::ByteEncoder e;
  encodeScan(e, scan, odometry);
  file_->append(e.bytes);
}

void InputLog::appendFloorEvent(const floor::FloorEvent& event) {
  common::ByteEncoder e;
  encodeEvent(e, event);
  file_->append(e.bytes);
}

}  // namespace storey::mapping
