#include "storey/runtime/component_registry.h"

#include <stdexcept>

namespace storey::runtime {

void ComponentRegistry::add(const std::string& kind, ComponentFactory factory,
                            std::string summary) {
  if (kind.empty()) throw std::invalid_argument("component kind must not be empty");
  if (!factory) throw std::invalid_argument("component kind '" + kind + "' has no factory");
  if (!entries_.emplace(kind, Entry{std::move(factory), std::move(summary)}).second) {
    throw std::invalid_argument("component kind '" + kind + "' is registered twice");
  }
}

std::vector<std::string> ComponentRegistry::kinds() const {
  std::vector<std::string> result;
  for (const auto& entry : entries_) result.push_back(entry.first);
  return result;
}

std::string ComponentRegistry::summary(const std::string& kind) const {
  auto it = entries_.find(kind);
  return it == entries_.end() ? "" : it->second.summary;
}

std::string ComponentRegistry::kindList() const {
  std::string list;
  for (const auto& entry : entries_) list += (list.empty() ? "" : ", ") + entry.first;
  return list.empty() ? "(none)" : list;
}

std::unique_ptr<Component> ComponentRegistry::create(const std::string& kind, Context& context,
                                                     const common::ConfigNode& parameters,
                                                     const std::string& name) const {
  auto it = entries_.find(kind);
  if (it == entries_.end()) {
    throw std::invalid_argument("unknown component kind '" + kind + "' (known: " + kindList() +
                                ")");
  }
  auto component = it->second.factory(context, parameters, name);
  if (!component) throw std::runtime_error("the factory of '" + kind + "' returned nothing");
  return component;
}

}  // namespace storey::runtime
