// Running components in one process: a ComponentGroup brings a list of components up
// (create, configure, activate, in order) and down (deactivate, cleanup, destroy, in
// reverse order) in one Context; runComponents adds the process loop: until SIGINT or
// SIGTERM, a component's requestFinish(), or a time limit.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "storey/common/config.h"
#include "storey/runtime/bringup.h"
#include "storey/runtime/component_registry.h"
#include "storey/runtime/context.h"

namespace storey::runtime {

class ComponentGroup {
 public:
  // Creates the components (constructors run here). Throws on an unknown kind or a bad
  // parameter file, naming the component.
  ComponentGroup(Context& context, const std::vector<ComponentSpec>& specs,
                 const ComponentRegistry& registry);
  ~ComponentGroup();  // stop()

  // Configures all (then checks each parameter file for unknown keys), then activates
  // all. On failure, what was brought up is brought down and the error (naming the
  // component, and the file/key/line for parameters) is thrown.
  void start();
  // Deactivates and cleans up in reverse order, then waits for queued callbacks, so the
  // components can be destroyed safely. Idempotent.
  void stop();

  std::size_t size() const { return entries_.size(); }
  Component& component(const std::string& name);

 private:
  struct Entry {
    ComponentSpec spec;
    common::ConfigNode parameters;
    std::unique_ptr<Component> component;
  };
  Context& context_;
  std::vector<Entry> entries_;
};

struct RunOptions {
  int domain_id = -1;       // see ContextOptions
  double duration_s = 0.0;  // > 0: stop after this many seconds
  std::string participant_name = "storey";
  std::string qos_profiles_file;
  int executor_threads = 1;
};

// Runs the components until SIGINT/SIGTERM, requestFinish() or the time limit, then
// shuts down in order. Returns 0 after a clean shutdown; throws on start-up errors.
// SIGINT and SIGTERM are blocked in the calling thread (and so in every thread it
// starts) while this runs, and taken with sigtimedwait.
int runComponents(const std::vector<ComponentSpec>& specs, const ComponentRegistry& registry,
                  const RunOptions& options);

}  // namespace storey::runtime
