// DDS Security between participants of one process (matching, where authentication and
// access control act, is the same as across processes): a secured talker and listener
// exchange messages; a participant that is unsecured or whose identity comes from another
// CA matches nobody; a participant with a valid identity but no grant for a topic can
// neither read nor write it. Artifacts come from initSecurityFolder (the openssl program).
#include "storey/runtime/security.h"

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <memory>
#include <mutex>
#include <thread>

#include "storey/runtime/context.h"
#include "storey/runtime/publisher.h"
#include "storey/runtime/subscription.h"
#include "storey_msgs/msg/FloorEvent.h"
#include "storey_msgs/msg/FloorEventPubSubTypes.h"
#include "test_support.h"

namespace storey::runtime {
namespace {

namespace fs = std::filesystem;
using EventPub = Publisher<storey_msgs::msg::FloorEvent, storey_msgs::msg::FloorEventPubSubType>;
using EventSub = Subscription<storey_msgs::msg::FloorEvent, storey_msgs::msg::FloorEventPubSubType>;

constexpr const char* kTopic = "chatter";  // DDS: rt/chatter
// Upper bound on discovery and delivery. The secured handshake (RSA signatures, DH) of
// four participants takes seconds when other tests load both cores; an idle run matches
// in well under one. Waits return as soon as their condition holds.
constexpr double kTimeout = 30.0;

template <typename Pred>
bool waitFor(Pred pred, double timeout_s) {
  const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  while (!pred()) {
    if (std::chrono::steady_clock::now() > end) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  return true;
}

// Two security folders made once: "ours" (talker, listener, intruder) and "foreign" (a
// talker and listener with full grants, signed by another CA).
class SecurityTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    root_ = new std::string(test::makeTempDir("storey-security"));
    SecurityInitOptions ours;
    ours.output_dir = *root_ + "/ours";
    ours.grants = {{"talker", {"rt/chatter"}, {}},
                   {"listener", {}, {"rt/chatter"}},
                   // Valid identity, but only rt/other.
                   {"intruder", {"rt/other"}, {"rt/other"}}};
    initSecurityFolder(ours);
    SecurityInitOptions foreign;
    foreign.output_dir = *root_ + "/foreign";
    foreign.grants = {{"talker", {"rt/*"}, {"rt/*"}}, {"listener", {"rt/*"}, {"rt/*"}}};
    initSecurityFolder(foreign);
  }
  static void TearDownTestSuite() {
    std::error_code ec;
    fs::remove_all(*root_, ec);
    delete root_;
  }

  static ContextOptions secured(const std::string& folder, const std::string& participant,
                                int domain) {
    ContextOptions options;
    options.domain_id = domain;
    options.participant_name = participant;
    options.security = securityFromFolder(*root_ + "/" + folder, participant);
    return options;
  }
  static ContextOptions unsecured(int domain) {
    ContextOptions options;
    options.domain_id = domain;
    options.participant_name = "unsecured";
    return options;
  }

  // Counts events received, and those whose robot field is `marker`.
  struct Counter {
    std::atomic<int> all{0};
    std::atomic<int> marked{0};
    std::string marker;
    std::unique_ptr<EventSub> sub;
    Counter(Context& context, const std::string& marker_value) : marker(marker_value) {
      sub = std::make_unique<EventSub>(context, kTopic, TopicKind::kGraph, [this](const auto& e) {
        ++all;
        if (e.robot() == marker) ++marked;
      });
    }
  };

  static storey_msgs::msg::FloorEvent event(const std::string& robot, int floor) {
    storey_msgs::msg::FloorEvent e;
    e.robot(robot);
    e.floor_id(floor);
    return e;
  }

  static std::string* root_;
};
std::string* SecurityTest::root_ = nullptr;

TEST_F(SecurityTest, FilesAndPropertiesFollowTheRecipe) {
  const SecurityOptions options = securityFromFolder(*root_ + "/ours", "talker");
  EXPECT_TRUE(options.enabled());
  const auto properties = securityProperties(options);
  std::map<std::string, std::string> by_name(properties.begin(), properties.end());
  EXPECT_EQ(by_name["dds.sec.auth.plugin"], "builtin.PKI-DH");
  EXPECT_EQ(by_name["dds.sec.access.plugin"], "builtin.Access-Permissions");
  EXPECT_EQ(by_name["dds.sec.crypto.plugin"], "builtin.AES-GCM-GMAC");
  EXPECT_EQ(by_name["dds.sec.auth.builtin.PKI-DH.private_key"].rfind("file:///", 0), 0u);
  // Subject in RFC 2253 order (most specific first) and default DENY.
  std::ifstream in(*root_ + "/ours/talker/permissions.xml");
  const std::string xml{std::istreambuf_iterator<char>(in), {}};
  EXPECT_NE(xml.find("<subject_name>CN=talker,O=storey</subject_name>"), std::string::npos);
  EXPECT_NE(xml.find("<default>DENY</default>"), std::string::npos);
  EXPECT_EQ(xml.find("<subscribe>"), std::string::npos);  // talker only publishes
  // Missing files and half-filled options are errors naming what is wrong.
  EXPECT_THROW(securityFromFolder(*root_ + "/ours", "nobody"), std::runtime_error);
  SecurityOptions half = options;
  half.permissions.clear();
  EXPECT_THROW(validateSecurityOptions(half), std::runtime_error);
  // A second init into the same folder would replace the CA: refused.
  SecurityInitOptions again;
  again.output_dir = *root_ + "/ours";
  EXPECT_THROW(initSecurityFolder(again), std::runtime_error);
  TopicGrant bad{"bad name", {}, {}};
  EXPECT_THROW(addSecurityParticipant(*root_ + "/ours", bad, again), std::runtime_error);
}

TEST_F(SecurityTest, SecuredTalkerAndListenerExchange) {
  Context listener(secured("ours", "listener", 220));
  Context talker(secured("ours", "talker", 220));
  Counter received(listener, "talker");
  EventPub pub(talker, kTopic, TopicKind::kGraph);
  ASSERT_TRUE(pub.waitForSubscribers(1, kTimeout)) << "secured peers did not match";
  for (int i = 0; i < 20; ++i) ASSERT_TRUE(pub.publish(event("talker", i)));
  EXPECT_TRUE(waitFor([&] { return received.marked == 20; }, kTimeout)) << received.marked;
}

// Unsecured and foreign-CA participants: receive nothing from the secured talker, and what
// they publish never reaches the secured listener (which does get the talker's messages).
TEST_F(SecurityTest, ParticipantWithoutValidIdentityIsIsolated) {
  struct Case {
    const char* what;
    int domain;
    bool foreign;
  };
  for (const Case& c : {Case{"unsecured", 221, false}, Case{"foreign CA", 222, true}}) {
    SCOPED_TRACE(c.what);
    // The outsiders first: they do match each other (the only thing keeping them out is
    // security), and their handshake then does not run beside the failing ones with ours.
    Context outsider_listener(c.foreign ? secured("foreign", "listener", c.domain)
                                        : unsecured(c.domain));
    Context outsider_talker(c.foreign ? secured("foreign", "talker", c.domain)
                                      : unsecured(c.domain));
    Counter outsider_received(outsider_listener, "talker");
    EventPub outsider_pub(outsider_talker, kTopic, TopicKind::kGraph);
    ASSERT_TRUE(outsider_pub.waitForSubscribers(1, kTimeout));
    Context listener(secured("ours", "listener", c.domain));
    Context talker(secured("ours", "talker", c.domain));
    Counter received(listener, "talker");
    EventPub pub(talker, kTopic, TopicKind::kGraph);
    ASSERT_TRUE(pub.waitForSubscribers(1, kTimeout));
    for (int i = 0; i < 20; ++i) {
      ASSERT_TRUE(pub.publish(event("talker", i)));
      ASSERT_TRUE(outsider_pub.publish(event("outsider", i)));
    }
    ASSERT_TRUE(waitFor([&] { return received.marked == 20; }, kTimeout));
    ASSERT_TRUE(waitFor([&] { return outsider_received.all == 20; }, kTimeout));
    std::this_thread::sleep_for(std::chrono::milliseconds(500));
    EXPECT_EQ(received.all, 20) << "an outsider's message reached the secured listener";
    EXPECT_EQ(outsider_received.marked, 0) << "the outsider read the secured talker";
    EXPECT_EQ(pub.matchedCount(), 1);
  }
}

TEST_F(SecurityTest, ValidIdentityWithoutPermissionReadsAndInjectsNothing) {
  Context listener(secured("ours", "listener", 223));
  Context talker(secured("ours", "talker", 223));
  Context intruder(secured("ours", "intruder", 223));
  Counter received(listener, "talker");
  EventPub pub(talker, kTopic, TopicKind::kGraph);
  // Access control refuses the intruder's reader and writer on rt/chatter outright.
  EXPECT_THROW(EventSub(intruder, kTopic, TopicKind::kGraph, [](const auto&) {}), DdsError);
  EXPECT_THROW(EventPub(intruder, kTopic, TopicKind::kGraph), DdsError);
  // The intruder is otherwise a working participant: its granted topic works.
  std::atomic<int> other{0};
  EventSub other_sub(intruder, "other", TopicKind::kGraph, [&](const auto&) { ++other; });
  EventPub other_pub(intruder, "other", TopicKind::kGraph);
  ASSERT_TRUE(other_pub.waitForSubscribers(1, kTimeout));
  ASSERT_TRUE(other_pub.publish(event("intruder", 1)));
  EXPECT_TRUE(waitFor([&] { return other == 1; }, kTimeout));
  // And the permitted pair is unaffected.
  ASSERT_TRUE(pub.waitForSubscribers(1, kTimeout));
  for (int i = 0; i < 5; ++i) ASSERT_TRUE(pub.publish(event("talker", i)));
  EXPECT_TRUE(waitFor([&] { return received.marked == 5; }, kTimeout));
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  EXPECT_EQ(received.all, 5);
  EXPECT_EQ(pub.matchedCount(), 1);
}

// Tampered security files: the participant is refused, and the error names the option,
// its file and the check it fails (Fast DDS says only that it cannot create the participant).
TEST_F(SecurityTest, TamperedFilesAreNamedWithTheCheckTheyFail) {
  struct Case {
    std::string what;      // the file altered, relative to the talker's folder copy
    std::string expected;  // in the error
  };
  const std::string ours = *root_ + "/ours";
  auto read = [](const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    return std::string{std::istreambuf_iterator<char>(in), {}};
  };
  for (const Case& c :
       {Case{"governance.p7s", "governance " + ours + "-tampered/governance.p7s: its signature"},
        Case{"talker/permissions.p7s",
             "permissions " + ours + "-tampered/talker/permissions.p7s: its signature"},
        Case{"talker/cert.pem",
             "private_key " + ours + "-tampered/talker/key.pem: does not belong"}}) {
    const std::string copy = ours + "-tampered";
    fs::remove_all(copy);
    fs::copy(ours, copy, fs::copy_options::recursive);
    if (c.what == "talker/cert.pem") {
      fs::copy_file(ours + "/listener/cert.pem", copy + "/talker/cert.pem",
                    fs::copy_options::overwrite_existing);
    } else {
      std::string text = read(copy + "/" + c.what);
      const auto at = text.find("<domains>") != std::string::npos ? text.find("<domains>")
                                                                  : text.find("<subject_name>");
      ASSERT_NE(at, std::string::npos) << c.what;
      text.insert(at, " ");  // one byte more in the signed XML
      std::ofstream(copy + "/" + c.what, std::ios::binary | std::ios::trunc) << text;
    }
    ContextOptions options;
    options.domain_id = 223;
    options.participant_name = "talker";
    options.security = securityFromFolder(copy, "talker");
    EXPECT_EQ(diagnoseSecurityFiles(securityFromFolder(ours, "talker")), "");
    try {
      Context context(options);
      ADD_FAILURE() << "a participant with a tampered " << c.what << " was created";
    } catch (const DdsError& e) {
      EXPECT_NE(std::string(e.what()).find(c.expected), std::string::npos) << e.what();
    }
  }
}

}  // namespace
}  // namespace storey::runtime
