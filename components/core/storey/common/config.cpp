#include "storey/common/config.h"

#include <cmath>
#include <cstdint>
#include <fstream>
#include <map>
#include <sstream>
#include <stdexcept>

#include "storey/common/file_checks.h"

namespace storey::common {
namespace {

std::string formatError(const std::string& file, int line, const std::string& key,
                        const std::string& problem) {
  std::ostringstream out;
  out << file;
  if (line > 0) out << ":" << line;
  out << ": ";
  if (!key.empty()) out << key << ": ";
  out << problem;
  return out.str();
}

template <typename T>
const char* typeName() {
  if constexpr (std::is_same_v<T, bool>) return "a boolean";
  if constexpr (std::is_integral_v<T>) return "an integer";
  if constexpr (std::is_floating_point_v<T>) return "a number";
  if constexpr (std::is_same_v<T, std::string>) return "a string";
  return "a value";
}

}  // namespace

ConfigError::ConfigError(const std::string& file, int line, const std::string& key,
                         const std::string& problem)
    : std::runtime_error(formatError(file, line, key, problem)),
      file_(file),
      line_(line),
      key_(key),
      problem_(problem) {}

ConfigNode ConfigNode::loadFile(const std::string& path) {
  try {
    requireRegularFile(path, "YAML file", kMaxYamlFileBytes);
  } catch (const std::runtime_error& e) {
    throw ConfigError(path, 0, "", std::string(e.what()).substr(path.size() + 2));
  }
  std::ifstream in(path);
  if (!in) throw ConfigError(path, 0, "", "cannot open file");
  std::stringstream text;
  text << in.rdbuf();
  return loadString(text.str(), path);
}

ConfigNode ConfigNode::loadString(const std::string& text, const std::string& name) {
  YAML::Node root;
  try {
    root = YAML::Load(text);
  } catch (const YAML::Exception& e) {
    throw ConfigError(name, e.mark.is_null() ? 0 : e.mark.line + 1, "", "malformed YAML: " + e.msg);
  }
  if (!root.IsMap()) throw ConfigError(name, 1, "", "the top level must be a mapping");
  requireUniqueKeys(root, name);
  return ConfigNode(root, name, "");
}

namespace {

void requireUniqueKeysAt(const YAML::Node& node, const std::string& file, const std::string& path) {
  if (node.IsSequence()) {
    for (std::size_t i = 0; i < node.size(); ++i)
      requireUniqueKeysAt(node[i], file, path + "[" + std::to_string(i) + "]");
    return;
  }
  if (!node.IsMap()) return;
  std::map<std::string, int> lines;  // key -> line where it first appears
  for (const auto& entry : node) {
    const std::string key = entry.first.IsScalar() ? entry.first.Scalar() : YAML::Dump(entry.first);
    const int line = entry.first.Mark().is_null() ? 0 : entry.first.Mark().line + 1;
    const std::string key_path = path.empty() ? key : path + "." + key;
    const auto [first, inserted] = lines.emplace(key, line);
    if (!inserted) {
      throw ConfigError(file, line, key_path,
                        "duplicate key (also on line " + std::to_string(first->second) +
                            "): only one value can be meant");
    }
    requireUniqueKeysAt(entry.second, file, key_path);
  }
}

}  // namespace

void requireUniqueKeys(const YAML::Node& root, const std::string& file) {
  requireUniqueKeysAt(root, file, "");
}

ConfigNode::ConfigNode(YAML::Node node, std::string file, std::string path)
    : node_(std::move(node)),
      file_(std::move(file)),
      path_(std::move(path)),
      used_(std::make_shared<std::set<std::string>>()) {}

int ConfigNode::line() const { return node_.Mark().is_null() ? 0 : node_.Mark().line + 1; }

std::string ConfigNode::keyPath(const std::string& key) const {
  return path_.empty() ? key : path_ + "." + key;
}

void ConfigNode::fail(const std::string& key, const std::string& problem) const {
  int at = line();
  if (!key.empty() && node_.IsMap()) {
    YAML::Node value = node_[key];
    if (value && !value.Mark().is_null()) at = value.Mark().line + 1;
  }
  throw ConfigError(file_, at, key.empty() ? path_ : keyPath(key), problem);
}

bool ConfigNode::has(const std::string& key) const {
  return node_.IsMap() && node_[key].IsDefined();
}

YAML::Node ConfigNode::lookup(const std::string& key) const {
  if (!node_.IsMap()) fail("", "expected a mapping");
  YAML::Node value = node_[key];
  if (!value.IsDefined()) fail(key, "missing required key");
  used_->insert(key);
  return value;
}

template <typename T>
T ConfigNode::convert(const YAML::Node& value, const std::string& key) const {
  if (!value.IsScalar()) fail(key, std::string("expected ") + typeName<T>());
  try {
    T result = value.as<T>();
    if constexpr (std::is_floating_point_v<T>) {
      if (!std::isfinite(result)) fail(key, "expected a finite number, got '" + value.Scalar() + "'");
    }
    return result;
  } catch (const YAML::Exception&) {
    fail(key, std::string("expected ") + typeName<T>() + ", got '" + value.Scalar() + "'");
  }
}

template <typename T>
T ConfigNode::get(const std::string& key) const {
  return convert<T>(lookup(key), key);
}

template <typename T>
T ConfigNode::get(const std::string& key, const T& default_value) const {
  if (!has(key)) return default_value;
  return get<T>(key);
}

template <typename T>
T ConfigNode::as() const {
  return convert<T>(node_, "");
}

double ConfigNode::getDouble(const std::string& key, double min, double max) const {
  const double value = get<double>(key);
  if (value < min || value > max) {
    std::ostringstream out;
    out << "value " << value << " is out of range [" << min << ", " << max << "]";
    fail(key, out.str());
  }
  return value;
}

double ConfigNode::getDouble(const std::string& key, double default_value, double min,
                             double max) const {
  return has(key) ? getDouble(key, min, max) : default_value;
}

int ConfigNode::getInt(const std::string& key, int min, int max) const {
  const int value = get<int>(key);
  if (value < min || value > max) {
    std::ostringstream out;
    out << "value " << value << " is out of range [" << min << ", " << max << "]";
    fail(key, out.str());
  }
  return value;
}

int ConfigNode::getInt(const std::string& key, int default_value, int min, int max) const {
  return has(key) ? getInt(key, min, max) : default_value;
}

std::string ConfigNode::getChoice(const std::string& key,
                                  const std::vector<std::string>& allowed) const {
  const std::string value = get<std::string>(key);
  for (const auto& option : allowed)
    if (option == value) return value;
  std::string list;
  for (const auto& option : allowed) list += (list.empty() ? "" : ", ") + option;
  fail(key, "'" + value + "' is not one of: " + list);
}

std::string ConfigNode::getChoice(const std::string& key, const std::string& default_value,
                                  const std::vector<std::string>& allowed) const {
  return has(key) ? getChoice(key, allowed) : default_value;
}

std::vector<double> ConfigNode::getDoubles(const std::string& key) const {
  std::vector<double> values;
  for (const auto& element : sequence(key)) values.push_back(element.as<double>());
  return values;
}

ConfigNode ConfigNode::child(const std::string& key) const {
  YAML::Node value = lookup(key);
  if (!value.IsMap()) fail(key, "expected a mapping");
  return ConfigNode(value, file_, keyPath(key));
}

std::vector<ConfigNode> ConfigNode::sequence(const std::string& key) const {
  YAML::Node value = lookup(key);
  if (!value.IsSequence()) fail(key, "expected a sequence");
  std::vector<ConfigNode> elements;
  for (std::size_t i = 0; i < value.size(); ++i)
    elements.emplace_back(value[i], file_, keyPath(key) + "[" + std::to_string(i) + "]");
  return elements;
}

std::vector<std::string> ConfigNode::keys() const {
  if (!node_.IsMap()) fail("", "expected a mapping");
  std::vector<std::string> result;
  for (const auto& entry : node_) {
    result.push_back(entry.first.as<std::string>());
    used_->insert(result.back());
  }
  return result;
}

void ConfigNode::finish() const {
  if (!node_.IsMap()) return;
  for (const auto& entry : node_) {
    const std::string key = entry.first.as<std::string>();
    if (!used_->count(key)) {
      const int at = entry.first.Mark().is_null() ? line() : entry.first.Mark().line + 1;
      throw ConfigError(file_, at, keyPath(key), "unknown key");
    }
  }
}

template bool ConfigNode::get<bool>(const std::string&) const;
template int ConfigNode::get<int>(const std::string&) const;
template int64_t ConfigNode::get<int64_t>(const std::string&) const;
template uint64_t ConfigNode::get<uint64_t>(const std::string&) const;
template uint32_t ConfigNode::get<uint32_t>(const std::string&) const;
template double ConfigNode::get<double>(const std::string&) const;
template std::string ConfigNode::get<std::string>(const std::string&) const;
template bool ConfigNode::get<bool>(const std::string&, const bool&) const;
template int ConfigNode::get<int>(const std::string&, const int&) const;
template int64_t ConfigNode::get<int64_t>(const std::string&, const int64_t&) const;
template uint64_t ConfigNode::get<uint64_t>(const std::string&, const uint64_t&) const;
template uint32_t ConfigNode::get<uint32_t>(const std::string&, const uint32_t&) const;
template double ConfigNode::get<double>(const std::string&, const double&) const;
template std::string ConfigNode::get<std::string>(const std::string&, const std::string&) const;
template bool ConfigNode::as<bool>() const;
template int ConfigNode::as<int>() const;
template double ConfigNode::as<double>() const;
template std::string ConfigNode::as<std::string>() const;

void overlayYaml(YAML::Node& base, const YAML::Node& overlay) {
  if (!overlay.IsMap()) throw std::invalid_argument("overlayYaml: the overlay must be a mapping");
  if (!base.IsMap()) base = YAML::Node(YAML::NodeType::Map);
  for (const auto& entry : overlay) {
    const std::string key = entry.first.as<std::string>();
    YAML::Node target = base[key];
    if (entry.second.IsMap() && target.IsMap()) overlayYaml(target, entry.second);
    else base[key] = YAML::Clone(entry.second);
  }
}

}  // namespace storey::common
