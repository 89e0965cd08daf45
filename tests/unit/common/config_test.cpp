#include "storey/common/config.h"

#include <gtest/gtest.h>

namespace storey::common {
namespace {

TEST(ConfigNode, ReadsRequiredAndOptionalKeys) {
  auto node = ConfigNode::loadString("a: 1.5\nb: hello\nc: {d: 3}\n", "test.yaml");
  EXPECT_DOUBLE_EQ(node.get<double>("a"), 1.5);
  EXPECT_EQ(node.get<std::string>("b"), "hello");
  EXPECT_EQ(node.get<int>("missing", 7), 7);
  auto c = node.child("c");
  EXPECT_EQ(c.getInt("d", 0, 10), 3);
  c.finish();
  node.finish();
}

TEST(ConfigNode, MissingKeyNamesFileAndKey) {
  auto node = ConfigNode::loadString("a: 1\n", "params.yaml");
  try {
    node.get<double>("b");
    FAIL() << "no error";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("params.yaml"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("b: missing required key"), std::string::npos) << e.what();
  }
}

TEST(ConfigNode, UnknownKeyNamesLine) {
  auto node = ConfigNode::loadString("a: 1\nsub:\n  x: 2\n  typo: 3\n", "p.yaml");
  node.get<int>("a");
  auto sub = node.child("sub");
  sub.get<int>("x");
  try {
    sub.finish();
    FAIL() << "no error";
  } catch (const ConfigError& e) {
    EXPECT_EQ(e.line(), 4);
    EXPECT_EQ(e.key(), "sub.typo");
    EXPECT_EQ(e.file(), "p.yaml");
  }
}

TEST(ConfigNode, WrongTypeAndRange) {
  auto node = ConfigNode::loadString("a: abc\nb: 12\nc: .nan\nd: [1]\n", "p.yaml");
  EXPECT_THROW(node.get<double>("a"), ConfigError);
  EXPECT_THROW(node.getDouble("b", 0.0, 10.0), ConfigError);
  EXPECT_THROW(node.get<double>("c"), ConfigError);
  EXPECT_THROW(node.get<double>("d"), ConfigError);
  try {
    node.getInt("b", 0, 10);
    FAIL();
  } catch (const ConfigError& e) {
    EXPECT_EQ(e.line(), 2);
    EXPECT_NE(std::string(e.what()).find("out of range"), std::string::npos);
  }
}

TEST(ConfigNode, MalformedYamlNamesLine) {
  try {
    ConfigNode::loadString("a: 1\nb: [1, 2\nc: 3\n", "bad.yaml");
    FAIL();
  } catch (const ConfigError& e) {
    EXPECT_EQ(e.file(), "bad.yaml");
    EXPECT_GT(e.line(), 1);
  }
  EXPECT_THROW(ConfigNode::loadFile("/nonexistent/storey.yaml"), ConfigError);
  EXPECT_THROW(ConfigNode::loadString("- 1\n- 2\n", "list.yaml"), ConfigError);
}

// YAML parsers keep one of two equal keys silently (yaml-cpp the first, and the second is
// never range-checked): refused anywhere in the file, naming both lines.
TEST(ConfigNode, DuplicateKeysNameBothLines) {
  auto errorOf = [](const std::string& text) {
    try {
      ConfigNode::loadString(text, "p.yaml");
    } catch (const ConfigError& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_EQ(errorOf("a: 1\nb: 2\na: -5\n"),
            "p.yaml:3: a: duplicate key (also on line 1): only one value can be meant");
  EXPECT_NE(errorOf("sub:\n  x: 1\n  y: 2\n  x: 3\n")
                .find("p.yaml:4: sub.x: duplicate key (also on line 2)"),
            std::string::npos);
  EXPECT_NE(errorOf("list:\n  - {n: 1, n: 2}\n").find("p.yaml:2: list[0].n: duplicate key"),
            std::string::npos);
  EXPECT_EQ(errorOf("a: 1\nb: {a: 2}\n"), "");  // the same key in different mappings is fine
}

TEST(ConfigNode, ChoicesAndSequences) {
  auto node = ConfigNode::loadString("k: huber\nv: [1, 2.5]\nitems:\n  - {n: 1}\n  - {n: 2}\n");
  EXPECT_EQ(node.getChoice("k", {"huber", "cauchy"}), "huber");
  EXPECT_THROW(node.getChoice("k", {"cauchy"}), ConfigError);
  EXPECT_EQ(node.getDoubles("v"), (std::vector<double>{1.0, 2.5}));
  auto items = node.sequence("items");
  ASSERT_EQ(items.size(), 2u);
  EXPECT_EQ(items[1].get<int>("n"), 2);
  EXPECT_EQ(items[1].path(), "items[1]");
}

TEST(OverlayYaml, SetsNestedKeysAndKeepsTheRest) {
  YAML::Node base = YAML::Load("a: 1\nslam: {matcher: {x: 1, y: 2}, list: [1, 2]}\nname: n");
  const YAML::Node overlay = YAML::Load("slam: {matcher: {y: 5, z: 6}, list: [3]}\nextra: {k: true}");
  overlayYaml(base, overlay);
  EXPECT_EQ(base["a"].as<int>(), 1);
  EXPECT_EQ(base["name"].as<std::string>(), "n");
  EXPECT_EQ(base["slam"]["matcher"]["x"].as<int>(), 1);
  EXPECT_EQ(base["slam"]["matcher"]["y"].as<int>(), 5);
  EXPECT_EQ(base["slam"]["matcher"]["z"].as<int>(), 6);
  ASSERT_EQ(base["slam"]["list"].size(), 1u);  // a sequence replaces, it is not appended to
  EXPECT_EQ(base["slam"]["list"][0].as<int>(), 3);
  EXPECT_TRUE(base["extra"]["k"].as<bool>());
  // The overlay is copied, not shared.
  EXPECT_EQ(overlay["slam"]["matcher"]["y"].as<int>(), 5);
  base["slam"]["matcher"]["y"] = 7;
  EXPECT_EQ(overlay["slam"]["matcher"]["y"].as<int>(), 5);
  EXPECT_THROW(overlayYaml(base, YAML::Load("[1, 2]")), std::invalid_argument);
}

}  // namespace
}  // namespace storey::common
