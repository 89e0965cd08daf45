// `storey bag info BAG`: what a rosbag2 bag holds (topics, types, counts, time span).
#include <cmath>
#include <ctime>
#include <filesystem>
#include <iomanip>
#include <iostream>
#include <sstream>

#include "args.h"
#include "storey/bag/bag_reader.h"

namespace storey::cli {
namespace {

std::string formatStamp(std::int64_t ns) {
  const std::time_t seconds = static_cast<std::time_t>(ns / 1'000'000'000);
  std::tm utc{};
  gmtime_r(&seconds, &utc);
  std::ostringstream out;
  out << std::put_time(&utc, "%Y-%m-%d %H:%M:%S") << " UTC (" << ns / 1'000'000'000 << "."
      << std::setw(9) << std::setfill('0') << ns % 1'000'000'000 << ")";
  return out.str();
}

std::string formatBytes(std::uintmax_t bytes) {
  std::ostringstream out;
  out << std::fixed << std::setprecision(1);
  if (bytes >= (1u << 30)) {
    out << bytes / double(1u << 30) << " GiB";
  } else if (bytes >= (1u << 20)) {
    out << bytes / double(1u << 20) << " MiB";
  } else if (bytes >= (1u << 10)) {
    out << bytes / double(1u << 10) << " KiB";
  } else {
    out << bytes << " B";
  }
  return out.str();
}

int info(const std::string& path) {
  bag::BagReader reader(path);
  std::uintmax_t size = 0;
  std::string files;
  for (const std::string& file : reader.files()) {
    std::error_code ec;
    size += std::filesystem::file_size(file, ec);
    files += (files.empty() ? "" : ", ") + std::filesystem::path(file).filename().string();
  }
  const auto& summary = reader.summary();
  const std::uint64_t count = reader.messageCount();
  const std::int64_t start = reader.startTimeNs(), end = reader.endTimeNs();
  std::cout << "Files:       " << files << "\n"
            << "Bag size:    " << formatBytes(size) << "\n"
            << "Storage:     " << reader.storage();
  if (reader.storage() == bag::kStorageSqlite3)
    std::cout << ", schema "
              << (reader.schemaVersion() ? std::to_string(reader.schemaVersion()) : "unknown")
              << (reader.rosDistro().empty() ? "" : ", " + reader.rosDistro());
  std::cout << "\n"
            << "Duration:    " << std::fixed << std::setprecision(3) << (end - start) * 1e-9
            << " s\n";
  if (count > 0) {
    std::cout << "Start:       " << formatStamp(start) << "\n"
              << "End:         " << formatStamp(end) << "\n";
  }
  std::cout << "Messages:    " << count << "\n"
            << "Topics:      " << summary.size() << "\n";
  std::size_t name_width = 5, type_width = 4;
  for (const auto& t : summary) {
    name_width = std::max(name_width, t.topic.name.size());
    type_width = std::max(type_width, t.topic.type.size());
  }
  for (const auto& t : summary) {
    std::cout << "  " << std::left << std::setw(static_cast<int>(name_width)) << t.topic.name
              << "  " << std::setw(static_cast<int>(type_width)) << t.topic.type << "  "
              << std::right << std::setw(8) << t.message_count << "  "
              << t.topic.serialization_format;
    if (t.message_count > 1) {
      const double span = (t.last_stamp_ns - t.first_stamp_ns) * 1e-9;
      if (span > 0) {
        std::cout << "  " << std::setprecision(1) << (t.message_count - 1) / span << " Hz";
      }
    }
    std::cout << "\n";
  }
  if (const auto& meta = reader.metadata(); meta && (meta->message_count != count)) {
    std::cout << "Warning: metadata.yaml says " << meta->message_count
              << " messages, the database holds " << count << "\n";
  }
  return 0;
}

}  // namespace

extern const char* const summary_bag = "inspect a rosbag2 bag (bag info BAG)";

int run_bag(Args& args) {
  args.usage("info BAG",
             "info: prints the topics, types, message counts, time span and duration of a\n"
             "rosbag2 bag (sqlite3 storage; a bag folder or a .db3 file).");
  if (!args.parse()) return 0;
  const std::string verb = args.positional(0, "verb (info)");
  if (verb != "info") throw UsageError("unknown verb '" + verb + "' (expected info)");
  if (args.positionals().size() > 2) throw UsageError("bag info takes one bag");
  return info(args.positional(1, "bag folder or .db3 file"));
}

}  // namespace storey::cli
