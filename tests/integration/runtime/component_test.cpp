// Components, their lifecycle, the registry and the in-process runner.
#include "storey/runtime/component.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <fstream>
#include <thread>

#include "storey/runtime/runner.h"
#include "storey_msgs/msg/FloorEvent.h"
#include "storey_msgs/msg/FloorEventPubSubTypes.h"
#include "test_components.h"
#include "test_support.h"

namespace storey::runtime {
namespace {

using FloorEvent = storey_msgs::msg::FloorEvent;
using FloorEventSub = Subscription<FloorEvent, storey_msgs::msg::FloorEventPubSubType>;

ContextOptions onDomain(int domain) {
  ContextOptions options;
  options.domain_id = domain;
  return options;
}

std::string writeFile(const std::string& dir, const std::string& name, const std::string& text) {
  const std::string path = dir + "/" + name;
  std::ofstream(path) << text;
  return path;
}

using test::readInts;

using test::testRegistry;

TEST(RuntimeComponent, LifecycleRunsInOrderAndStopsInReverse) {
  test::clearLifecycleLog();
  const auto registry = testRegistry();
  {
    Context context(onDomain(110));
    ComponentGroup group(context, {{"test_recorder", "a", ""}, {"test_recorder", "b", ""}},
                         registry);
    group.start();
    EXPECT_EQ(group.component("a").state(), LifecycleState::kActive);
    group.stop();
  }
  const std::vector<std::string> expected{
      "a:construct",  "b:construct",  "a:configure", "b:configure", "a:activate", "b:activate",
      "b:deactivate", "a:deactivate", "b:cleanup",   "a:cleanup",   "b:destroy",  "a:destroy"};
  EXPECT_EQ(test::lifecycleLog(), expected);
}

TEST(RuntimeComponent, WrongTransitionsAreRefused) {
  Context context(onDomain(111));
  const auto registry = testRegistry();
  const auto params = common::ConfigNode::loadString("{}");
  auto component = registry.create("test_recorder", context, params, "r");
  EXPECT_THROW(component->activate(), std::logic_error);
  EXPECT_THROW(component->cleanup(), std::logic_error);
  component->configure();
  EXPECT_THROW(component->configure(), std::logic_error);
  EXPECT_THROW(component->deactivate(), std::logic_error);
  component->activate();
  try {
    component->activate();
    FAIL() << "activate twice was accepted";
  } catch (const std::logic_error& e) {
    EXPECT_NE(std::string(e.what()).find("'r'"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("active"), std::string::npos) << e.what();
  }
  component->shutdown();
  EXPECT_EQ(component->state(), LifecycleState::kUnconfigured);
}

TEST(RuntimeComponent, NothingIsPublishedBeforeActivate) {
  Context context(onDomain(112));
  const auto registry = testRegistry();
  std::mutex mutex;
  std::vector<int> floors;
  // A transient-local subscriber would also receive anything written before it matched.
  FloorEventSub sub(context, "talk", TopicKind::kGraph, [&](const FloorEvent& e) {
    std::lock_guard<std::mutex> lock(mutex);
    floors.push_back(e.floor_id());
  });
  const auto params = common::ConfigNode::loadString("{topic: talk, rate_hz: 100}");
  auto talker = registry.create("test_talker", context, params, "talker");
  talker->configure();
  // 30 timer periods while inactive: no tick may publish or advance the counter.
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  {
    std::lock_guard<std::mutex> lock(mutex);
    EXPECT_TRUE(floors.empty());
  }
  talker->activate();
  const auto end = std::chrono::steady_clock::now() + std::chrono::seconds(5);
  for (;;) {
    {
      std::lock_guard<std::mutex> lock(mutex);
      if (floors.size() >= 3 || std::chrono::steady_clock::now() > end) break;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  talker->shutdown();
  context.executor().drain();
  std::lock_guard<std::mutex> lock(mutex);
  ASSERT_GE(floors.size(), 3u);
  EXPECT_EQ(floors[0], 0);
  EXPECT_EQ(floors[1], 1);
  EXPECT_EQ(floors[2], 2);
}

TEST(RuntimeComponent, FailedConfigureNamesTheComponentAndUnwinds) {
  test::clearLifecycleLog();
  const auto dir = storey::test::makeTempDir("runtime_component");
  const auto bad = writeFile(dir, "bad.yaml", "fail_configure: true\n");
  const auto registry = testRegistry();
  Context context(onDomain(113));
  ComponentGroup group(context, {{"test_recorder", "a", ""}, {"test_recorder", "b", bad}},
                       registry);
  try {
    group.start();
    FAIL() << "start succeeded";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("component 'b' (test_recorder)"), std::string::npos)
        << e.what();
    EXPECT_NE(std::string(e.what()).find("configure fails on purpose"), std::string::npos);
  }
  const auto log = test::lifecycleLog();
  EXPECT_NE(std::find(log.begin(), log.end(), "a:cleanup"), log.end());
  EXPECT_EQ(std::find(log.begin(), log.end(), "a:activate"), log.end());
}

TEST(RuntimeComponent, UnknownParameterIsReportedWithFileKeyAndLine) {
  const auto dir = storey::test::makeTempDir("runtime_component");
  const auto params = writeFile(dir, "talker.yaml", "topic: t\nrate_hz: 10\nrate_hx: 5\n");
  const auto registry = testRegistry();
  Context context(onDomain(114));
  ComponentGroup group(context, {{"test_talker", "talker", params}}, registry);
  try {
    group.start();
    FAIL() << "start succeeded";
  } catch (const std::runtime_error& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find(params + ":3"), std::string::npos) << what;
    EXPECT_NE(what.find("rate_hx"), std::string::npos) << what;
    EXPECT_NE(what.find("unknown key"), std::string::npos) << what;
    EXPECT_NE(what.find("'talker'"), std::string::npos) << what;
  }
}

TEST(RuntimeComponent, MissingOrBadParameterIsReported) {
  const auto dir = storey::test::makeTempDir("runtime_component");
  const auto missing = writeFile(dir, "missing.yaml", "rate_hz: 10\n");
  const auto range = writeFile(dir, "range.yaml", "topic: t\nrate_hz: -1\n");
  const auto registry = testRegistry();
  Context context(onDomain(115));
  for (const auto& [file, key] : {std::pair{missing, "topic"}, std::pair{range, "rate_hz"}}) {
    ComponentGroup group(context, {{"test_talker", "talker", file}}, registry);
    try {
      group.start();
      FAIL() << "start succeeded with " << file;
    } catch (const std::runtime_error& e) {
      EXPECT_NE(std::string(e.what()).find(file), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find(key), std::string::npos) << e.what();
    }
  }
}

TEST(RuntimeComponent, RegistryRefusesDuplicatesAndNamesKnownKinds) {
  auto registry = testRegistry();
  EXPECT_THROW(
      registry.add("test_talker", [](Context&, const common::ConfigNode&,
                                     const std::string&) { return std::unique_ptr<Component>(); }),
      std::invalid_argument);
  Context context(onDomain(116));
  try {
    registry.create("test_talkr", context, common::ConfigNode::loadString("{}"), "t");
    FAIL() << "unknown kind accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("test_talker"), std::string::npos) << e.what();
  }
}

TEST(RuntimeRunner, RunsUntilAComponentFinishes) {
  const auto dir = storey::test::makeTempDir("runtime_runner");
  const auto out = dir + "/received.txt";
  const auto talker = writeFile(dir, "talker.yaml", "topic: chatter\nrate_hz: 200\n");
  const auto listener = writeFile(dir, "listener.yaml",
                                  "topic: chatter\nfinish_after: 10\noutput_file: " + out + "\n");
  RunOptions options;
  options.domain_id = 117;
  options.duration_s = 15;  // safety net; the listener finishes long before
  const auto start = std::chrono::steady_clock::now();
  EXPECT_EQ(
      runComponents({{"test_listener", "listener", listener}, {"test_talker", "talker", talker}},
                    testRegistry(), options),
      0);
  EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::seconds(10));
  const auto floors = readInts(out);
  ASSERT_GE(floors.size(), 10u);
  for (int i = 0; i < 10; ++i) EXPECT_EQ(floors[i], i);
}

}  // namespace
}  // namespace storey::runtime

namespace storey::runtime {
namespace {

TEST(RuntimeComponent, HooksRunOnTheExecutorAndErrorsReachTheCaller) {
  Context context(onDomain(118));
  std::atomic<bool> on_worker{false};
  context.executor().invoke([&] { on_worker = context.executor().onWorkerThread(); });
  EXPECT_TRUE(on_worker);
  EXPECT_THROW(context.executor().invoke([] { throw std::runtime_error("boom"); }),
               std::runtime_error);
  // From a worker, invoke runs inline (no deadlock).
  std::atomic<int> depth{0};
  context.executor().invoke([&] { context.executor().invoke([&] { depth = 2; }); });
  EXPECT_EQ(depth, 2);
}

}  // namespace
}  // namespace storey::runtime
