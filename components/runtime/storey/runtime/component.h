// A component: a thin class constructed from (Context, parameters, name) with a
// lifecycle, in the style of ROS 2 lifecycle nodes:
//
//   unconfigured --configure--> inactive --activate--> active
//   unconfigured <--cleanup---- inactive <--deactivate-- active
//
// Publishers made with createPublisher() are inactive until activate(): nothing leaves
// a component before activation. deactivate() first calls onDeactivating() with the
// publishers still active, so work in flight (a background pass) publishes its results,
// then silences the publishers and calls onDeactivate(). Timers made with createTimer() only fire
// while active. Subscriptions deliver in every state once created (so transient-local history that
// arrives before activate is not lost); callbacks can check state().
// Callbacks of all kinds, and the lifecycle hooks, run on the Context's Executor: with
// one worker (the default) a component's hooks and callbacks never run concurrently.
// So a hook must not wait for a callback of the same Context (it would wait forever).
#pragma once

#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "storey/common/config.h"
#include "storey/runtime/context.h"
#include "storey/runtime/publisher.h"
#include "storey/runtime/subscription.h"

namespace storey::runtime {

enum class LifecycleState { kUnconfigured, kInactive, kActive };
const char* toString(LifecycleState state);

class Component {
 public:
  Component(Context& context, const common::ConfigNode& parameters, std::string name);
  virtual ~Component();
  Component(const Component&) = delete;
  Component& operator=(const Component&) = delete;

  // Transitions; each throws std::logic_error (naming the component and states) when
  // called in the wrong state. If an on*() hook throws, the state does not change and
  // configure() releases what the hook created.
  void configure();
  void activate();
  void deactivate();
  void cleanup();
  // From any state back to unconfigured (deactivate and cleanup as needed).
  void shutdown();

  LifecycleState state() const;
  const std::string& name() const { return name_; }

  // Finishes the work on everything this component has received so far and publishes the
  // results (e.g. the mapper's last optimisation, the matcher's pending matching), then
  // returns true; false if that took longer than `timeout_s`. The caller drains the
  // executor first. Used to end a replay deterministically (`storey map`); components
  // without background work keep the default.
  virtual bool flush(double timeout_s) {
    (void)timeout_s;
    return true;
  }

 protected:
  // Read options in onConfigure (from parameters()) and create publishers,
  // subscriptions and timers there.
  virtual void onConfigure() {}
  virtual void onActivate() {}
  // First step of deactivate(), publishers still active: start nothing new, and finish and
  // publish what is in flight.
  virtual void onDeactivating() {}
  virtual void onDeactivate() {}
  virtual void onCleanup() {}

  template <typename MsgT, typename PubSubT>
  std::shared_ptr<Publisher<MsgT, PubSubT>> createPublisher(const std::string& topic,
                                                            TopicKind kind) {
    auto publisher = std::make_shared<Publisher<MsgT, PubSubT>>(context_, topic, kind,
                                                                state() == LifecycleState::kActive);
    std::lock_guard<std::mutex> lock(mutex_);
    publishers_.push_back(publisher);
    return publisher;
  }
  template <typename MsgT, typename PubSubT>
  std::shared_ptr<Subscription<MsgT, PubSubT>> createSubscription(
      const std::string& topic, TopicKind kind,
      typename Subscription<MsgT, PubSubT>::Callback callback) {
    auto subscription =
        std::make_shared<Subscription<MsgT, PubSubT>>(context_, topic, kind, std::move(callback));
    std::lock_guard<std::mutex> lock(mutex_);
    subscriptions_.push_back(subscription);
    return subscription;
  }
  // Periodic callback on the executor, skipped while not active; cancelled on cleanup.
  Executor::TimerId createTimer(double period_s, std::function<void()> callback);

  // Asks the process runner to shut the process down (e.g. a replay has finished).
  void requestFinish() { context_.requestShutdown(); }

  Context& context() { return context_; }
  Executor& executor() { return context_.executor(); }
  const common::ConfigNode& parameters() const { return parameters_; }

 private:
  void releaseEntities();

  Context& context_;
  common::ConfigNode parameters_;
  std::string name_;
  mutable std::mutex mutex_;
  LifecycleState state_ = LifecycleState::kUnconfigured;
  std::vector<std::shared_ptr<PublisherBase>> publishers_;
  std::vector<std::shared_ptr<SubscriptionBase>> subscriptions_;
  std::vector<Executor::TimerId> timers_;
};

}  // namespace storey::runtime
