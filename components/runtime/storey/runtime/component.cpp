#include "storey/runtime/component.h"

#include <stdexcept>

namespace storey::runtime {

const char* toString(LifecycleState state) {
  switch (state) {
    case LifecycleState::kUnconfigured:
      return "unconfigured";
    case LifecycleState::kInactive:
      return "inactive";
    case LifecycleState::kActive:
      return "active";
  }
  return "?";
}

Component::Component(Context& context, const common::ConfigNode& parameters, std::string name)
    : context_(context), parameters_(parameters), name_(std::move(name)) {}

Component::~Component() {
  // Subclass hooks cannot run here (the subclass is gone): owners call shutdown() first.
  releaseEntities();
}

LifecycleState Component::state() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return state_;
}

namespace {
void requireState(const std::string& name, const char* transition, LifecycleState actual,
                  LifecycleState required) {
  if (actual != required) {
    throw std::logic_error("component '" + name + "': cannot " + transition + " when " +
                           toString(actual) + " (needs " + toString(required) + ")");
  }
}
}  // namespace

void Component::configure() {
  executor().invoke([this] {
    requireState(name_, "configure", state(), LifecycleState::kUnconfigured);
    try {
      onConfigure();
    } catch (...) {
      releaseEntities();
      throw;
    }
    std::lock_guard<std::mutex> lock(mutex_);
    state_ = LifecycleState::kInactive;
  });
}

void Component::activate() {
  executor().invoke([this] {
    requireState(name_, "activate", state(), LifecycleState::kInactive);
    onActivate();
    std::lock_guard<std::mutex> lock(mutex_);
    state_ = LifecycleState::kActive;
    for (auto& publisher : publishers_) publisher->setActive(true);
  });
}

void Component::deactivate() {
  executor().invoke([this] {
    requireState(name_, "deactivate", state(), LifecycleState::kActive);
    onDeactivating();  // what is in flight still goes out
    {
      // Publishers go quiet before onDeactivate, so nothing is sent while deactivating.
      std::lock_guard<std::mutex> lock(mutex_);
      for (auto& publisher : publishers_) publisher->setActive(false);
      state_ = LifecycleState::kInactive;
    }
    onDeactivate();
  });
}

void Component::cleanup() {
  executor().invoke([this] {
    requireState(name_, "clean up", state(), LifecycleState::kInactive);
    onCleanup();
    releaseEntities();
    std::lock_guard<std::mutex> lock(mutex_);
    state_ = LifecycleState::kUnconfigured;
  });
}

void Component::shutdown() {
  if (state() == LifecycleState::kActive) deactivate();
  if (state() == LifecycleState::kInactive) cleanup();
}

Executor::TimerId Component::createTimer(double period_s, std::function<void()> callback) {
  const Executor::TimerId id = context_.executor().addTimer(period_s, [this, callback] {
    if (state() == LifecycleState::kActive) callback();
  });
  std::lock_guard<std::mutex> lock(mutex_);
  timers_.push_back(id);
  return id;
}

void Component::releaseEntities() {
  std::vector<Executor::TimerId> timers;
  std::vector<std::shared_ptr<PublisherBase>> publishers;
  std::vector<std::shared_ptr<SubscriptionBase>> subscriptions;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    timers.swap(timers_);
    publishers.swap(publishers_);
    subscriptions.swap(subscriptions_);
  }
  for (auto id : timers) context_.executor().cancelTimer(id);
  // Entities are destroyed here unless the subclass still holds them.
}

}  // namespace storey::runtime
