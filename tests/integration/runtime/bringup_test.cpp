// Bringup files: what a good one gives, and that bad ones fail naming file, key and line.
#include "storey/runtime/bringup.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "test_components.h"
#include "test_support.h"

namespace storey::runtime {
namespace {

using test::testRegistry;

class BringupTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = storey::test::makeTempDir("runtime_bringup");
    write("params/talker.yaml", "topic: chatter\nrate_hz: 10\n");
  }
  std::string write(const std::string& name, const std::string& text) {
    const std::string path = dir_ + "/" + name;
    std::filesystem::create_directories(std::filesystem::path(path).parent_path());
    std::ofstream(path) << text;
    return path;
  }
  // The error readBringup throws for `text`, or "" when it accepts it.
  std::string errorFor(const std::string& text) {
    const auto path = write("bringup.yaml", text);
    try {
      readBringup(path, testRegistry());
    } catch (const common::ConfigError& e) {
      return e.what();
    }
    return "";
  }
  std::string dir_;
};

TEST_F(BringupTest, ReadsProcessesAndResolvesParameterFiles) {
  const auto path =
      write("bringup.yaml",
            "processes:\n"
            "  - name: robot\n"
            "    domain_id: 7\n"
            "    components:\n"
            "      - {kind: test_talker, name: talker, parameters: params/talker.yaml}\n"
            "  - name: server\n"
            "    components:\n"
            "      - {kind: test_listener, name: listener}\n");
  const Bringup bringup = readBringup(path, testRegistry());
  ASSERT_EQ(bringup.processes.size(), 2u);
  EXPECT_EQ(bringup.processes[0].name, "robot");
  EXPECT_EQ(bringup.processes[0].domain_id, 7);
  EXPECT_EQ(bringup.processes[1].domain_id, -1);
  ASSERT_EQ(bringup.processes[0].components.size(), 1u);
  EXPECT_EQ(bringup.processes[0].components[0].kind, "test_talker");
  EXPECT_EQ(bringup.processes[0].components[0].parameters_file, dir_ + "/params/talker.yaml");
  EXPECT_EQ(bringup.processes[1].components[0].parameters_file, "");
  EXPECT_EQ(bringup.process("server").name, "server");
  EXPECT_THROW(bringup.process("nobody"), std::invalid_argument);
}

struct BadCase {
  const char* text;
  const char* expected[3];  // substrings of the error (after the file name)
};

TEST_F(BringupTest, BadFilesNameFileKeyAndLine) {
  const BadCase cases[] = {
      {"process: []\n", {":1", "processes", ""}},
      {"processes:\n  - name: a\n    components:\n      - {kind: test_talkr, name: x}\n",
       {":4", "processes[0].components[0].kind", "unknown component kind 'test_talkr'"}},
      {"processes:\n  - name: a\n    components:\n      - kind: test_talker\n        name: x\n"
       "        parameters: nowhere.yaml\n",
       {":6", "processes[0].components[0].parameters", "nowhere.yaml does not exist"}},
      {"processes:\n  - name: a\n    components:\n      - kind: test_talker\n        name: x\n"
       "        paramters: p.yaml\n",
       {":6", "paramters", "unknown key"}},
      {"processes:\n  - name: a\n    domain_id: 999\n    components:\n"
       "      - {kind: test_talker, name: x}\n",
       {":3", "processes[0].domain_id", ""}},
      {"processes:\n  - name: a\n    components:\n      - {kind: test_talker, name: x}\n"
       "  - name: b\n    components:\n      - {kind: test_listener, name: x}\n",
       {":7", "processes[1].components[0].name", "appears twice"}},
      {"processes:\n  - name: a\n    components:\n      - {kind: test_talker}\n",
       {":4", "processes[0].components[0].name", ""}},
      {"processes:\n  - name: a\n    components: []\n", {":3", "components", "no component"}},
      {"processes:\n  - name: a\n    components: [\n", {":", "malformed YAML", ""}},
  };
  for (const auto& c : cases) {
    const std::string error = errorFor(c.text);
    SCOPED_TRACE(c.text);
    ASSERT_FALSE(error.empty()) << "accepted";
    EXPECT_EQ(error.find(dir_ + "/bringup.yaml"), 0u) << error;
    for (const char* part : c.expected) {
      EXPECT_NE(error.find(part), std::string::npos) << "'" << part << "' not in: " << error;
    }
  }
}

TEST_F(BringupTest, MalformedParameterFileIsNamed) {
  write("params/broken.yaml", "topic: [unclosed\n");
  const std::string error = errorFor(
      "processes:\n  - name: a\n    components:\n"
      "      - {kind: test_talker, name: x, parameters: params/broken.yaml}\n");
  EXPECT_NE(error.find(dir_ + "/params/broken.yaml"), std::string::npos) << error;
  EXPECT_NE(error.find("malformed YAML"), std::string::npos) << error;
}

TEST_F(BringupTest, StoreyLaunchReportsABadFile) {
  const auto path = write("bad.yaml",
                          "processes:\n  - name: a\n    components:\n"
                          "      - {kind: no_such_kind, name: x}\n");
  if (!std::filesystem::exists(STOREY_EXECUTABLE)) {
    GTEST_SKIP() << STOREY_EXECUTABLE << " is not built (sanitizer builds leave it out)";
  }
  const auto [status, output] =
      storey::test::runCommand(std::string(STOREY_EXECUTABLE) + " launch " + path);
  EXPECT_EQ(status, 1) << output;
  EXPECT_NE(output.find(path + ":4"), std::string::npos) << output;
  EXPECT_NE(output.find("unknown component kind 'no_such_kind'"), std::string::npos) << output;
}

}  // namespace
}  // namespace storey::runtime
