#include "storey/runtime/bringup.h"

#include <filesystem>
#include <set>
#include <stdexcept>

namespace storey::runtime {

namespace fs = std::filesystem;

const ProcessSpec& Bringup::process(const std::string& name) const {
  for (const auto& process : processes) {
    if (process.name == name) return process;
  }
  std::string known;
  for (const auto& process : processes) known += (known.empty() ? "" : ", ") + process.name;
  throw std::invalid_argument("bringup " + file + " has no process '" + name +
                              "' (processes: " + known + ")");
}

common::ConfigNode loadParameters(const ComponentSpec& spec) {
  if (spec.parameters_file.empty()) {
    return common::ConfigNode::loadString("{}", "<no parameter file for " + spec.name + ">");
  }
  return common::ConfigNode::loadFile(spec.parameters_file);
}

Bringup readBringup(const std::string& path, const ComponentRegistry& registry) {
  const common::ConfigNode root = common::ConfigNode::loadFile(path);
  const fs::path base = fs::absolute(fs::path(path)).parent_path();
  Bringup bringup;
  bringup.file = path;
  std::set<std::string> process_names;
  std::set<std::string> component_names;
  const auto processes = root.sequence("processes");
  if (processes.empty()) root.fail("processes", "names no process");
  for (const auto& p : processes) {
    ProcessSpec process;
    process.name = p.get<std::string>("name");
    if (process.name.empty()) p.fail("name", "must not be empty");
    if (!process_names.insert(process.name).second) {
      p.fail("name", "process '" + process.name + "' appears twice");
    }
    if (p.has("domain_id")) process.domain_id = p.getInt("domain_id", 0, 232);
    const auto components = p.sequence("components");
    if (components.empty()) p.fail("components", "names no component");
    for (const auto& c : components) {
      ComponentSpec spec;
      spec.kind = c.get<std::string>("kind");
      if (!registry.has(spec.kind)) {
        c.fail("kind",
               "unknown component kind '" + spec.kind + "' (known: " + registry.kindList() + ")");
      }
      spec.name = c.get<std::string>("name");
      if (spec.name.empty()) c.fail("name", "must not be empty");
      if (!component_names.insert(spec.name).second) {
        c.fail("name", "component '" + spec.name + "' appears twice");
      }
      if (c.has("parameters")) {
        const fs::path given = c.get<std::string>("parameters");
        const fs::path resolved = given.is_absolute() ? given : base / given;
        if (!fs::is_regular_file(resolved)) {
          c.fail("parameters", "parameter file " + resolved.string() + " does not exist");
        }
        spec.parameters_file = resolved.lexically_normal().string();
        loadParameters(spec);  // malformed YAML fails now, naming the parameter file
      }
      c.finish();
      process.components.push_back(std::move(spec));
    }
    p.finish();
    bringup.processes.push_back(std::move(process));
  }
  root.finish();
  return bringup;
}

}  // namespace storey::runtime
