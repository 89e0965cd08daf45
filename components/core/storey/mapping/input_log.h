// The floor mapper's input log: every input the InputSequencer passed on (a scan with its
// odometry, or a floor event), in that order, appended before it is mapped. Mapping is
// deterministic given this sequence, so a restarted mapper that replays its log rebuilds
// exactly the floor graphs it had (and the same stream of updates, re-published for
// subscribers that joined since), then goes on with new input. Records are framed and
// CRC-checked (common::RecordFileWriter); a torn last record is dropped. Appends are not
// fdatasync'ed: a killed process loses nothing, a power cut may lose the last records.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "storey/common/record_file.h"
#include "storey/floor/floor_event.h"
#include "storey/geometry/pose2.h"
#include "storey/sensor/laser_scan.h"

namespace storey::mapping {

struct LoggedInput {
  bool is_scan = true;
  sensor::LaserScan scan;     // is_scan
  geometry::Pose2 odometry;   // is_scan: odometry at the scan's stamp
  floor::FloorEvent event;    // !is_scan: TransitStarted or TransitEnded
};

class InputLog {
 public:
  // Opens `path` (created if missing); the inputs already in it are passed to
  // `on_existing` in order. Throws std::runtime_error (naming the file and offset) for a
  // file that is not an input log or is corrupt before its last record.
  InputLog(const std::string& path, const std::function<void(const LoggedInput&)>& on_existing);

  void appendScan(const sensor::LaserScan& scan, const geometry::Pose2& odometry);
  void appendFloorEvent(const floor::FloorEvent& event);

  std::size_t existingInputs() const { return file_->existingRecords(); }
  // Of the inputs read at opening (-inf when there were none).
  double lastScanStamp() const { return last_scan_stamp_; }
  double lastEventDecidedAt() const { return last_event_decided_at_; }

 private:
  double last_scan_stamp_ = -1e300;
  double last_event_decided_at_ = -1e300;
  std::unique_ptr<common::RecordFileWriter> file_;
};

// For `storey journal check|salvage`: whether a file starts like an input log, its state
// (every record decoded), and a copy of its intact records in a new file `out`.
bool looksLikeInputLog(const std::string& path);
common::RecordFileScan scanInputLog(const std::string& path);
common::RecordFileScan salvageInputLog(const std::string& in, const std::string& out);

// Encoding, exposed for tests and fuzzing; decodeLoggedInput throws std::runtime_error on
// bad bytes.
std::vector<std::uint8_t> encodeLoggedInput(const LoggedInput& input);
LoggedInput decodeLoggedInput(const std::uint8_t* data, std::size_t size);

}  // namespace storey::mapping
