// Strict YAML configuration: every key an options struct reads is required unless a
// default is given, every key present must be read (finish() reports the rest as
// unknown), and every error names the file, the key path and the line.
#pragma once

#include <yaml-cpp/yaml.h>

#include <cstdint>
#include <limits>
#include <memory>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

namespace storey::common {

// Thrown for any bad configuration; what() reads "file:line: key.path: problem".
class ConfigError : public std::runtime_error {
 public:
  ConfigError(const std::string& file, int line, const std::string& key, const std::string& problem);
  const std::string& file() const { return file_; }
  int line() const { return line_; }
  const std::string& key() const { return key_; }
  const std::string& problem() const { return problem_; }

 private:
  std::string file_;
  int line_;
  std::string key_;
  std::string problem_;
};

// Larger YAML files are refused before reading (parameters, buildings, bringups are
// kilobytes; the parsed tree takes many times the text).
inline constexpr std::uint64_t kMaxYamlFileBytes = 16ull << 20;

// A YAML mapping (or sequence element) being read strictly.
class ConfigNode {
 public:
  static ConfigNode loadFile(const std::string& path);
  static ConfigNode loadString(const std::string& text, const std::string& name = "<string>");
  ConfigNode(YAML::Node node, std::string file, std::string path);

  bool has(const std::string& key) const;

  // Required scalar of type T (bool, int, int64_t, double, std::string, ...).
  template <typename T>
  T get(const std::string& key) const;
  // Optional scalar: the default when the key is absent (an explicit null is an error).
  template <typename T>
  T get(const std::string& key, const T& default_value) const;
  // Required number within [min, max].
  double getDouble(const std::string& key, double min = -std::numeric_limits<double>::infinity(),
                   double max = std::numeric_limits<double>::infinity()) const;
  double getDouble(const std::string& key, double default_value, double min, double max) const;
  int getInt(const std::string& key, int min = std::numeric_limits<int>::min(),
             int max = std::numeric_limits<int>::max()) const;
  int getInt(const std::string& key, int default_value, int min, int max) const;
  // One of the allowed strings.
  std::string getChoice(const std::string& key, const std::vector<std::string>& allowed) const;
  std::string getChoice(const std::string& key, const std::string& default_value,
                        const std::vector<std::string>& allowed) const;
  std::vector<double> getDoubles(const std::string& key) const;

  // Required child mapping.
  ConfigNode child(const std::string& key) const;
  // Required sequence; each element is a node of its own (mapping or scalar).
  std::vector<ConfigNode> sequence(const std::string& key) const;
  // Keys of this mapping in file order (for maps keyed by name); marks them all read.
  std::vector<std::string> keys() const;

  // This node as a scalar (for sequence elements).
  template <typename T>
  T as() const;
  bool isMap() const { return node_.IsMap(); }
  bool isSequence() const { return node_.IsSequence(); }
  bool isScalar() const { return node_.IsScalar(); }

  // Throws for the first key of this mapping that was never read.
  void finish() const;

  [[noreturn]] void fail(const std::string& key, const std::string& problem) const;
  const std::string& file() const { return file_; }
  const std::string& path() const { return path_; }
  int line() const;  // 1-based line of this node
  const YAML::Node& yaml() const { return node_; }

 private:
  YAML::Node lookup(const std::string& key) const;
  std::string keyPath(const std::string& key) const;
  template <typename T>
  T convert(const YAML::Node& value, const std::string& key) const;

  YAML::Node node_;
  std::string file_;
  std::string path_;
  std::shared_ptr<std::set<std::string>> used_;
};

// Throws ConfigError naming the file, the key path and both lines for a mapping anywhere
// in `root` that holds the same key twice (YAML parsers keep one of the values silently).
// loadFile and loadString check it.
void requireUniqueKeys(const YAML::Node& root, const std::string& file);

// Sets every key of the mapping `overlay` on `base`, descending into mappings present in
// both; any other value (scalar, sequence, a mapping over a non-mapping) replaces.
void overlayYaml(YAML::Node& base, const YAML::Node& overlay);

}  // namespace storey::common
