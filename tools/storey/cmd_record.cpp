// `storey record`: subscribes to DDS topics and writes them into a rosbag2 bag.
#include <chrono>
#include <iostream>
#include <thread>

#include "args.h"
#include "storey/common/log.h"
#include "storey/runtime/bag_recorder.h"
#include "storey/runtime/context.h"
#include "storey/runtime/signals.h"

namespace storey::cli {

extern const char* const summary_record = "record DDS topics into a rosbag2 bag";

int run_record(Args& args) {
  std::string known;
  for (const std::string& type : runtime::BagRecorder::knownTypes()) known += "\n  " + type;
  args.usage("--topics A,B[:TYPE] --output BAG [--duration S]",
             "Subscribes to the topics (ROS 2 names, DDS topics rt/<name>) and writes every\n"
             "message into a new rosbag2 bag folder, stamped with its receive time. A topic's\n"
             "type is given as NAME:TYPE, or inferred from its last name token (scan, odom,\n"
             "pressure, imu, tf, tf_static), or else taken from a discovered publisher.\n"
             "tf_static is subscribed reliable and transient local (transforms sent before\n"
             "the recording started are recorded too), as ros2 bag record does; the bag\n"
             "stores the QoS the publishers offered. Stops on SIGINT/SIGTERM, after\n"
             "--duration, or after --count messages. Types storey can record:" +
                 known)
      .option("topics", "A,B,...", "topics to record (comma-separated)")
      .option("output", "BAG", "bag folder to create (must not exist or be empty)")
      .option("duration", "SECONDS", "stop after this long (0: until stopped)", "0")
      .option("count", "N", "stop after N messages (0: no limit)", "0")
      .option("storage", "sqlite3|mcap", "the bag's storage (rosbag2's storage identifier)",
              "sqlite3")
      .option("domain", "ID", "DDS domain id (-1: ROS_DOMAIN_ID, else 0)", "-1")
      .option("discovery-timeout", "SECONDS", "wait for publishers to tell topic types", "5");
  if (!args.parse()) return 0;
  if (!args.positionals().empty())
    throw UsageError("unexpected argument " + args.positional(0, ""));
  if (!args.has("topics")) throw UsageError("--topics is required");
  if (!args.has("output")) throw UsageError("--output is required");
  const std::string storage = args.getChoice("storage", {bag::kStorageSqlite3, bag::kStorageMcap});
  const double duration = args.getDouble("duration");
  const long count = args.getInt("count");
  if (duration < 0) throw UsageError("--duration must not be negative");
  if (count < 0) throw UsageError("--count must not be negative");
  std::vector<runtime::RecordTopic> topics;
  try {
    topics = runtime::parseRecordTopics(args.get("topics"));
  } catch (const std::invalid_argument& e) {
    throw UsageError(std::string("--topics: ") + e.what());
  }

  // Before any DDS thread starts, so that they all inherit the blocked signals.
  runtime::BlockedTerminationSignals signals;
  runtime::ContextOptions options;
  options.domain_id = static_cast<int>(args.getInt("domain"));
  options.participant_name = "storey_record";
  runtime::Context context(options);
  try {
    runtime::resolveTopicTypes(context, topics, args.getDouble("discovery-timeout"));
  } catch (const std::invalid_argument& e) {
    throw UsageError(std::string("--topics: ") + e.what());
  }
  runtime::BagRecorder recorder(context, args.get("output"), topics, storage);
  common::logInfo(common::str("recording ", topics.size(), " topics on domain ", context.domainId(),
                              " into ", args.get("output")));

  const auto start = std::chrono::steady_clock::now();
  int signal = 0;
  while (true) {
    if (count > 0 && recorder.messageCount() >= static_cast<std::uint64_t>(count)) break;
    const double elapsed =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    if (duration > 0 && elapsed >= duration) break;
    signal = signals.wait(0.05);
    if (signal) break;
  }
  recorder.close();
  const auto counts = recorder.countsByTopic();
  std::cout << "recorded " << recorder.messageCount() << " messages into " << args.get("output")
            << (signal ? " (interrupted)" : "") << "\n";
  for (const runtime::RecordTopic& topic : topics) {
    const auto it = counts.find(topic.name);
    std::cout << "  " << topic.name << "  " << topic.type << "  "
              << (it == counts.end() ? 0 : it->second) << "\n";
  }
  return 0;
}

}  // namespace storey::cli
