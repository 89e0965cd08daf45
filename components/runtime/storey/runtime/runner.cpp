#include "storey/runtime/runner.h"

#include <chrono>
#include <csignal>
#include <cstring>
#include <ctime>
#include <stdexcept>

#include "storey/common/log.h"
#include "storey/runtime/signals.h"

namespace storey::runtime {

ComponentGroup::ComponentGroup(Context& context, const std::vector<ComponentSpec>& specs,
                               const ComponentRegistry& registry)
    : context_(context) {
  for (const auto& spec : specs) {
    try {
      Entry entry{spec, loadParameters(spec), nullptr};
      entry.component = registry.create(spec.kind, context_, entry.parameters, spec.name);
      entries_.push_back(std::move(entry));
    } catch (const std::exception& e) {
      stop();
      throw std::runtime_error("component '" + spec.name + "' (" + spec.kind + "): " + e.what());
    }
  }
}

ComponentGroup::~ComponentGroup() {
  try {
    stop();
  } catch (const std::exception& e) {
    common::log(common::LogLevel::kError, std::string("stopping components: ") + e.what());
  }
}

void ComponentGroup::start() {
  std::size_t i = 0;
  try {
    for (; i < entries_.size(); ++i) {
      entries_[i].component->configure();
      entries_[i].parameters.finish();
    }
    for (i = 0; i < entries_.size(); ++i) entries_[i].component->activate();
  } catch (const std::exception& e) {
    const Entry& failed = entries_[i < entries_.size() ? i : entries_.size() - 1];
    const std::string message =
        "component '" + failed.spec.name + "' (" + failed.spec.kind + "): " + e.what();
    stop();
    throw std::runtime_error(message);
  }
}

void ComponentGroup::stop() {
  for (auto it = entries_.rbegin(); it != entries_.rend(); ++it) {
    if (it->component && it->component->state() == LifecycleState::kActive) {
      it->component->deactivate();
    }
  }
  for (auto it = entries_.rbegin(); it != entries_.rend(); ++it) {
    if (it->component) it->component->shutdown();
  }
  // A timer tick or posted task may still be queued with a pointer to a component.
  if (!context_.executor().isShutDown() && !context_.executor().onWorkerThread()) {
    context_.executor().drain();
  }
  while (!entries_.empty()) entries_.pop_back();  // destroy in reverse order
}

Component& ComponentGroup::component(const std::string& name) {
  for (auto& entry : entries_) {
    if (entry.spec.name == name) return *entry.component;
  }
  throw std::invalid_argument("no component named '" + name + "'");
}

int runComponents(const std::vector<ComponentSpec>& specs, const ComponentRegistry& registry,
                  const RunOptions& options) {
  installCrashReport();
  // Blocked before the Context starts any thread, so every thread inherits the mask and
  // the signals wait for sigtimedwait below.
  BlockedTerminationSignals blocked;
  ContextOptions context_options;
  context_options.domain_id = options.domain_id;
  context_options.participant_name = options.participant_name;
  context_options.qos_profiles_file = options.qos_profiles_file;
  context_options.executor_threads = options.executor_threads;
  Context context(context_options);
  ComponentGroup group(context, specs, registry);
  group.start();
  common::logInfo(
      common::str("running ", group.size(), " component(s) on domain ", context.domainId()));
  const auto start = std::chrono::steady_clock::now();
  for (;;) {
    const int signal = blocked.wait(0.05);
    if (signal != 0) {
      common::logInfo(common::str("received ", strsignal(signal), ": shutting down"));
      break;
    }
    if (context.shutdownRequested()) {
      common::logInfo("a component asked to finish: shutting down");
      break;
    }
    if (options.duration_s > 0 && std::chrono::steady_clock::now() - start >=
                                      std::chrono::duration<double>(options.duration_s)) {
      break;
    }
  }
  group.stop();
  return 0;
}

}  // namespace storey::runtime
