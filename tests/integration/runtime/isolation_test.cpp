// Isolated contexts (ContextOptions::isolated, what offline jobs run on) and the warning
// for a second writer of a robot's sensor topic.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <iterator>
#include <string>
#include <thread>

#include "sensor_msgs/msg/LaserScan.h"
#include "sensor_msgs/msg/LaserScanPubSubTypes.h"
#include "storey/runtime/context.h"
#include "storey/runtime/publisher.h"
#include "storey/runtime/subscription.h"
#include "storey_msgs/msg/FloorEvent.h"
#include "storey_msgs/msg/FloorEventPubSubTypes.h"
#include "test_support.h"

namespace storey::runtime {
namespace {

using EventPub = Publisher<storey_msgs::msg::FloorEvent, storey_msgs::msg::FloorEventPubSubType>;
using EventSub = Subscription<storey_msgs::msg::FloorEvent, storey_msgs::msg::FloorEventPubSubType>;
using ScanPub = Publisher<sensor_msgs::msg::LaserScan, sensor_msgs::msg::LaserScanPubSubType>;
using ScanSub = Subscription<sensor_msgs::msg::LaserScan, sensor_msgs::msg::LaserScanPubSubType>;

template <typename Pred>
bool waitUntil(Pred pred, double timeout_s) {
  const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  while (!pred()) {
    if (std::chrono::steady_clock::now() > end) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  return true;
}

ContextOptions isolationTestOptions(int domain, bool isolated) {
  ContextOptions options;
  options.domain_id = domain;
  options.isolated = isolated;
  options.participant_name = isolated ? "isolated" : "open";
  return options;
}

// Counts events by sender (FloorEvent::robot).
struct Tally {
  std::atomic<int> own{0}, others{0};
  void take(const storey_msgs::msg::FloorEvent& e) { (e.robot() == "self" ? own : others)++; }
};

// A talker in another process publishes on the topic; an open context in this process
// hears it, so the talker is there to be heard. An isolated context on the same domain
// with a reader and a writer on the same topic gets its own messages and none of the
// talker's (whose history is transient local: a match at any time would deliver it),
// and the open context never gets the isolated one's.
TEST(RuntimeIsolation, AnIsolatedContextMatchesItselfAndNoOtherParticipant) {
  constexpr int kDomain = 228;
  const std::string dir = storey::test::makeTempDir("runtime_isolation");
  std::ofstream(dir + "/talker.yaml") << "topic: chatter\nrate_hz: 50\n";
  std::ofstream(dir + "/bringup.yaml")
      << "processes:\n  - name: talker_process\n    domain_id: " << kDomain
      << "\n    components:\n"
         "      - {kind: test_talker, name: talker, parameters: talker.yaml}\n";
  const pid_t talker = fork();
  ASSERT_GE(talker, 0);
  if (talker == 0) {
    execl(RUNTIME_TEST_NODE, RUNTIME_TEST_NODE, "--bringup", (dir + "/bringup.yaml").c_str(),
          "--process", "talker_process", static_cast<char*>(nullptr));
    _exit(127);
  }
  struct Stop {
    pid_t pid;
    ~Stop() {
      kill(pid, SIGTERM);
      waitpid(pid, nullptr, 0);
    }
  } stop{talker};

  Context open(isolationTestOptions(kDomain, false));
  Tally heard_open;
  EventSub open_sub(open, "chatter", TopicKind::kGraph, [&](const auto& e) { heard_open.take(e); });
  ASSERT_TRUE(waitUntil([&] { return heard_open.others >= 5; }, 20.0))
      << "the talker process was not heard";

  Context isolated(isolationTestOptions(kDomain, true));
  EXPECT_TRUE(isolated.isolated());
  Tally heard_isolated;
  EventSub isolated_sub(isolated, "chatter", TopicKind::kGraph,
                        [&](const auto& e) { heard_isolated.take(e); });
  EventPub isolated_pub(isolated, "chatter", TopicKind::kGraph);
  ASSERT_TRUE(isolated_pub.waitForSubscribers(1, 5.0));
  for (int i = 0; i < 20; ++i) {
    storey_msgs::msg::FloorEvent event;
    event.robot("self");
    event.floor_id(i);
    ASSERT_TRUE(isolated_pub.publish(event));
  }
  ASSERT_TRUE(waitUntil([&] { return heard_isolated.own == 20; }, 5.0)) << heard_isolated.own;
  // Discovery among the open participants takes well under a second here (the open
  // context heard the talker); give a match with the isolated one three.
  const int open_before = heard_open.others;
  std::this_thread::sleep_for(std::chrono::seconds(3));
  EXPECT_GT(heard_open.others, open_before) << "the talker stopped";
  EXPECT_EQ(heard_isolated.others, 0);
  EXPECT_EQ(heard_open.own, 0);
  EXPECT_EQ(isolated_sub.matchedCount(), 1);
  EXPECT_EQ(isolated_pub.matchedCount(), 1);
  EXPECT_EQ(open_sub.matchedCount(), 1);  // the talker only
}

// Two writers of robot1/scan (two replays of the same robot name) reach a reader: a
// warning names the topic. Two writers of a graph topic are normal (every mapper
// publishes floor graphs) and are not warned about.
TEST(RuntimeIsolation, ASecondWriterOfASensorTopicIsWarned) {
  constexpr int kDomain = 229;
  // stderr goes to a file while the writers match: the listener logs on a DDS thread,
  // possibly after the matched count is visible, so the file is read until the line shows.
  const std::string path = storey::test::makeTempDir("runtime_second_writer") + "/stderr.log";
  std::fflush(stderr);
  const int saved = dup(2);
  const int file = open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0600);
  ASSERT_GE(file, 0);
  dup2(file, 2);
  auto logged = [&] {
    std::ifstream in(path);
    return std::string{std::istreambuf_iterator<char>(in), {}};
  };
  bool matched = false, warned = false;
  {
    Context reader(isolationTestOptions(kDomain, false));
    ScanSub scans(reader, "robot1/scan", TopicKind::kSensor, [](const auto&) {});
    EventSub graphs(reader, "floor_graphs_like", TopicKind::kGraph, [](const auto&) {});
    Context first(isolationTestOptions(kDomain, false)),
        second(isolationTestOptions(kDomain, false));
    ScanPub scan_a(first, "robot1/scan", TopicKind::kSensor),
        scan_b(second, "robot1/scan", TopicKind::kSensor);
    EventPub graph_a(first, "floor_graphs_like", TopicKind::kGraph),
        graph_b(second, "floor_graphs_like", TopicKind::kGraph);
    matched =
        waitUntil([&] { return scans.matchedCount() == 2 && graphs.matchedCount() == 2; }, 10.0);
    warned = waitUntil(
        [&] {
          return logged().find("sensor topic robot1/scan has 2 writers") != std::string::npos;
        },
        10.0);
  }
  dup2(saved, 2);
  close(saved);
  close(file);
  const std::string log = logged();
  ASSERT_TRUE(matched);
  EXPECT_TRUE(warned) << log;
  EXPECT_EQ(log.find("floor_graphs_like has"), std::string::npos) << log;
}

}  // namespace
}  // namespace storey::runtime
