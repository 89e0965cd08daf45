// storey replay INPUT: publishes a recording (rosbag2 bag or CARMEN log) over DDS.
#include <csignal>
#include <cstdlib>
#include <iostream>

#include "args.h"
#include "storey/runtime/context.h"
#include "storey/tools/map_job.h"
#include "storey/tools/replay.h"
#include "storey/tools/robot_setup.h"

namespace storey::cli {

extern const char* const summary_replay = "publish a recording (bag or CARMEN log) over DDS";

namespace {
std::atomic<bool> g_stop{false};
void onSignal(int) { g_stop = true; }
}  // namespace

int run_replay(Args& args) {
  args.usage(
          "INPUT [--rate R]",
          "Publishes the sensor messages of INPUT (a rosbag2 bag folder or a CARMEN log) on\n"
          "the robots' scan, odom, pressure and imu topics, in recorded order: those --config's\n"
          "floor_mapper.yaml and floor_detector.yaml name (scan_topic ...; shipped: <robot>/scan).")
      .option("rate", "R", "0: as fast as possible; 1: recorded rate; k: k times faster", "1")
      .option("robot", "NAME", "robot name for CARMEN logs (bags carry their own)", "robot")
      .option("prefix", "P", "prepended to every topic name", "")
      .option("config", "DIR",
              "parameter files naming the robots' topics (default: shipped config/)", "")
      .option("domain", "ID", "DDS domain id (default: ROS_DOMAIN_ID, else 0)", "-1")
      .option("wait", "SECONDS", "wait this long before publishing, for subscribers to appear", "1")
      .option("subscribers", "N",
              "first wait until each topic of a robot has a subscriber and its scan topic N, then "
              "--wait",
              "0")
      .option("ack-wait", "SECONDS",
              "at the end, wait this long at most for reliable subscribers' acknowledgments", "3")
      .flag("quiet", "no progress bar");
  if (!args.parse()) return 0;
  const std::string input = args.positional(0, "INPUT");
  tools::ReplayOptions options;
  options.rate = args.getDouble("rate");
  if (options.rate < 0) throw UsageError("--rate must not be negative");
  options.log_robot = args.get("robot");
  options.topic_prefix = args.get("prefix");
  options.topics =
      tools::sensorTopics(args.has("config") ? args.get("config") : tools::defaultConfigDir());
  options.settle_seconds = args.getDouble("wait");
  options.ack_seconds = args.getDouble("ack-wait");
  if (options.ack_seconds < 0) throw UsageError("--ack-wait must not be negative");
  options.min_subscribers = static_cast<int>(args.getInt("subscribers"));
  if (options.min_subscribers < 0) throw UsageError("--subscribers must not be negative");
  runtime::ContextOptions context_options;
  context_options.domain_id = static_cast<int>(args.getInt("domain"));
  context_options.participant_name = "storey_replay";
  auto source = tools::openSensorSource(input, options);
  runtime::Context context(context_options);
  tools::SensorReplayer replayer(context, options);
  std::signal(SIGINT, onSignal);
  std::signal(SIGTERM, onSignal);
  const bool quiet = args.flagSet("quiet");
  const auto summary = replayer.replay(*source, &g_stop, [&](std::uint64_t done, std::uint64_t expected) {
    if (quiet) return;
    if (expected > 0) {
      const int width = 30, filled = static_cast<int>(width * double(done) / double(expected));
      std::cerr << "\r[" << std::string(filled, '#') << std::string(width - filled, ' ') << "] " << done << "/"
                << expected << std::flush;
    } else {
      std::cerr << "\r" << done << " messages" << std::flush;
    }
  });
  if (!quiet) std::cerr << "\n";
  std::cout << summary.text() << std::flush;
  // Leave without deleting the writers: Fast DDS 2.9 can hang deleting a reliable writer
  // whose subscriber was killed (seen in the fault tests: RTPSWriter::deinit waiting on a
  // mutex). The OS closes the sockets; peers drop us after our lease.
  std::cerr << std::flush;
  std::_Exit(summary.stopped ? 130 : 0);
}

}  // namespace storey::cli
