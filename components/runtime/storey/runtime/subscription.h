// Typed subscription on a ROS 2-named topic. The DDS listener thread only schedules a
// drain on the Context's Executor; samples are taken and the callback runs there.
// Do not destroy a Subscription from inside its own callback.
#pragma once

#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <string>

#include "storey/common/log.h"
#include "storey/runtime/context.h"
#include "storey/runtime/dds.h"

namespace storey::runtime {

class SubscriptionBase {
 public:
  virtual ~SubscriptionBase() = default;
  virtual const std::string& topic() const = 0;
  virtual std::uint64_t receivedCount() const = 0;
  virtual int matchedCount() const = 0;
};

template <typename MsgT, typename PubSubT>
class Subscription : public SubscriptionBase {
 public:
  using Callback = std::function<void(const MsgT&)>;

  Subscription(Context& context, const std::string& topic, TopicKind kind, Callback callback)
      : context_(context), state_(std::make_shared<State>()) {
    state_->topic = topic;
    state_->callback = std::move(callback);
    state_->executor = &context.executor();
    listener_ = std::make_unique<Listener>(state_);
    // Held so that a drain scheduled by an early delivery waits for `reader` to be set.
    std::lock_guard<std::mutex> lock(state_->mutex);
    state_->reader = context_.createReader<PubSubT>(topic, kind, listener_.get());
  }

  ~Subscription() override {
    // After delete_datareader the listener is never called again; queued drains see
    // `closed` and return without touching the reader.
    {
      std::lock_guard<std::mutex> lock(state_->mutex);
      state_->closed = true;
    }
    context_.deleteReader(state_->reader);
  }
  Subscription(const Subscription&) = delete;
  Subscription& operator=(const Subscription&) = delete;

  const std::string& topic() const override { return state_->topic; }
  std::uint64_t receivedCount() const override { return state_->received; }
  int matchedCount() const override {
    eprosima::fastdds::dds::SubscriptionMatchedStatus status;
    state_->reader->get_subscription_matched_status(status);
    return status.current_count;
  }

 private:
  struct State {
    std::string topic;
    Callback callback;
    Executor* executor = nullptr;
    eprosima::fastdds::dds::DataReader* reader = nullptr;
    std::mutex mutex;  // held while draining, so the destructor waits for a running drain
    bool closed = false;
    std::atomic<bool> drain_queued{false};
    std::atomic<std::uint64_t> received{0};
  };

  static void drain(const std::shared_ptr<State>& state) {
    std::lock_guard<std::mutex> lock(state->mutex);
    if (state->closed) return;
    state->drain_queued = false;  // later arrivals queue another drain
    MsgT sample;
    eprosima::fastdds::dds::SampleInfo info;
    while (state->reader->take_next_sample(&sample, &info) == ReturnCode_t::RETCODE_OK) {
      if (!info.valid_data) continue;
      ++state->received;
      try {
        state->callback(sample);
      } catch (const std::exception& e) {
        common::logError(
            common::str("subscription on ", state->topic, ": callback failed: ", e.what()));
      }
    }
  }

  class Listener : public eprosima::fastdds::dds::DataReaderListener {
   public:
    explicit Listener(std::weak_ptr<State> state) : state_(std::move(state)) {}
    void on_data_available(eprosima::fastdds::dds::DataReader*) override {
      auto state = state_.lock();
      if (!state || state->drain_queued.exchange(true)) return;
      std::weak_ptr<State> weak = state;
      state->executor->post([weak] {
        if (auto s = weak.lock()) drain(s);
      });
    }

   private:
    std::weak_ptr<State> state_;
  };

  Context& context_;
  std::shared_ptr<State> state_;
  std::unique_ptr<Listener> listener_;
};

}  // namespace storey::runtime
