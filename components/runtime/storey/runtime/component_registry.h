// The table of component kinds: kind name -> factory. Filled explicitly (no static
// initialisers, which the linker may drop): storey's own kinds by
// registerStoreyComponents() (storey/catalog/all_components.h), tests by hand.
#pragma once

#include <functional>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "storey/common/config.h"
#include "storey/runtime/component.h"

namespace storey::runtime {

using ComponentFactory = std::function<std::unique_ptr<Component>(
    Context& context, const common::ConfigNode& parameters, const std::string& name)>;

class ComponentRegistry {
 public:
  // Throws std::invalid_argument if `kind` is already registered.
  void add(const std::string& kind, ComponentFactory factory, std::string summary = "");
  // Shorthand for a class constructible from (Context&, const ConfigNode&, std::string).
  template <typename ComponentT>
  void add(const std::string& kind, std::string summary = "") {
    add(
        kind,
        [](Context& context, const common::ConfigNode& parameters, const std::string& name) {
          return std::make_unique<ComponentT>(context, parameters, name);
        },
        std::move(summary));
  }

  bool has(const std::string& kind) const { return entries_.count(kind) > 0; }
  std::vector<std::string> kinds() const;
  std::string summary(const std::string& kind) const;
  // Throws std::invalid_argument naming the known kinds when `kind` is unknown.
  std::unique_ptr<Component> create(const std::string& kind, Context& context,
                                    const common::ConfigNode& parameters,
                                    const std::string& name) const;
  // "a, b, c" (for error messages).
  std::string kindList() const;

 private:
  struct Entry {
    ComponentFactory factory;
    std::string summary;
  };
  std::map<std::string, Entry> entries_;
};

}  // namespace storey::runtime
