// Build-time generator: turns the shipped configuration files (config/*.yaml) into one C++
// header of constants, so that the options structs' defaults are the shipped files' values
// and nothing else. Usage: generate_shipped_config OUT.h FILE.yaml...
// Each file becomes namespace storey::shipped::<file stem>, each mapping a nested
// namespace, each scalar an inline constexpr bool, int, double or char array. Sequences are
// left out (the structs' empty defaults stand for `[]`).
#include <yaml-cpp/yaml.h>

#include <cstdio>
#include <fstream>
#include <iostream>
#include <regex>
#include <set>
#include <sstream>
#include <stdexcept>
#include <string>

namespace {

const std::set<std::string>& keywords() {
  static const std::set<std::string> k = {
      "alignas",   "alignof",  "and",   "asm",      "auto",     "bool",     "break",     "case",
      "catch",     "char",     "class", "const",    "continue", "default",  "delete",    "do",
      "double",    "else",     "enum",  "explicit", "export",   "extern",   "false",     "float",
      "for",       "friend",   "goto",  "if",       "inline",   "int",      "long",      "mutable",
      "namespace", "new",      "not",   "operator", "or",       "private",  "protected", "public",
      "register",  "return",   "short", "signed",   "sizeof",   "static",   "struct",    "switch",
      "template",  "this",     "throw", "true",     "try",      "typedef",  "typeid",    "typename",
      "union",     "unsigned", "using", "virtual",  "void",     "volatile", "while"};
  return k;
}

std::string where(const std::string& file, const YAML::Node& node) {
  return file + ":" + std::to_string(node.Mark().line + 1);
}

std::string identifier(const std::string& key, const std::string& file, const YAML::Node& node) {
  static const std::regex valid("[a-z_][a-z0-9_]*");
  if (!std::regex_match(key, valid) || keywords().count(key))
    throw std::runtime_error(where(file, node) + ": key '" + key +
                             "' is not usable as a C++ name (lower case, digits, _)");
  return key;
}

std::string quoted(const std::string& text) {
  std::string out = "\"";
  for (char c : text) {
    if (c == '"' || c == '\\') out += '\\';
    out += c;
  }
  return out + "\"";
}

void emitScalar(std::ostream& out, const std::string& name, const YAML::Node& value,
                const std::string& indent) {
  static const std::regex integer("[-+]?[0-9]+");
  static const std::regex real("[-+]?([0-9]+\\.?[0-9]*|\\.[0-9]+)([eE][-+]?[0-9]+)?");
  const std::string& text = value.Scalar();
  if (value.Tag() != "!" && (text == "true" || text == "false")) {
    out << indent << "inline constexpr bool " << name << " = " << text << ";\n";
  } else if (value.Tag() != "!" && std::regex_match(text, integer)) {
    out << indent << "inline constexpr int " << name << " = " << text << ";\n";
  } else if (value.Tag() != "!" && std::regex_match(text, real)) {
    out << indent << "inline constexpr double " << name << " = " << text << ";\n";
  } else {
    out << indent << "inline constexpr char " << name << "[] = " << quoted(text) << ";\n";
  }
}

void emitMap(std::ostream& out, const YAML::Node& map, const std::string& file,
             const std::string& indent) {
  for (const auto& entry : map) {
    const std::string name = identifier(entry.first.Scalar(), file, entry.first);
    const YAML::Node& value = entry.second;
    if (value.IsMap()) {
      out << indent << "namespace " << name << " {\n";
      emitMap(out, value, file, indent + "  ");
      out << indent << "}  // namespace " << name << "\n";
    } else if (value.IsScalar()) {
      emitScalar(out, name, value, indent);
    } else if (!value.IsSequence()) {
      throw std::runtime_error(where(file, entry.first) + ": key '" + name + "' has no value");
    }
  }
}

std::string stem(const std::string& path) {
  const std::size_t slash = path.find_last_of('/');
  std::string name = slash == std::string::npos ? path : path.substr(slash + 1);
  const std::size_t dot = name.find('.');
  return dot == std::string::npos ? name : name.substr(0, dot);
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 3) {
    std::cerr << "usage: generate_shipped_config OUT.h FILE.yaml...\n";
    return 2;
  }
  try {
    std::ostringstream out;
    out << "// Generated from the shipped configuration files at build time: do not edit.\n"
           "#pragma once\n\nnamespace storey::shipped {\n";
    for (int i = 2; i < argc; ++i) {
      const std::string file = argv[i];
      const YAML::Node root = YAML::LoadFile(file);
      if (!root.IsMap()) throw std::runtime_error(file + ": not a mapping");
      const std::string name = stem(file);
      out << "namespace " << identifier(name, file, root) << " {  // config/" << name << ".yaml\n";
      emitMap(out, root, file, "  ");
      out << "}  // namespace " << name << "\n";
    }
    out << "}  // namespace storey::shipped\n";
    // Rewritten only when it changes, so that a touched file recompiles nothing.
    std::string previous;
    if (std::ifstream in(argv[1]); in) previous.assign(std::istreambuf_iterator<char>(in), {});
    if (previous != out.str()) {
      std::ofstream file(argv[1], std::ios::trunc);
      file << out.str();
      if (!file) throw std::runtime_error(std::string(argv[1]) + ": cannot write");
    }
  } catch (const std::exception& e) {
    std::cerr << "generate_shipped_config: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
