// Typed subscription on a ROS 2-named topic. The DDS thread that delivers a sample takes
// it and schedules a drain on the Context's Executor; the callback runs there.
// Do not destroy a Subscription from inside its own callback.
#pragma once

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <deque>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

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
    state_->kind = kind;
    state_->callback = std::move(callback);
    state_->executor = &context.executor();
    listener_ = std::make_unique<Listener>(state_);
    reader_ = context_.createReader<PubSubT>(topic, kind, listener_.get());
    // Samples handed over before this line are all kept, which errs on the safe side.
    const auto& history = reader_->get_qos().history();
    std::lock_guard<std::mutex> lock(state_->queue_mutex);
    state_->depth =
        history.kind == eprosima::fastdds::dds::KEEP_LAST_HISTORY_QOS && history.depth > 0
            ? static_cast<std::size_t>(history.depth)
            : 0;
  }

  ~Subscription() override {
    // After delete_datareader the listener is never called again; queued drains see
    // `closed` and return. Taking callback_mutex waits for a running callback.
    {
      std::lock_guard<std::mutex> lock(state_->callback_mutex);
      state_->closed = true;
    }
    context_.deleteReader(reader_);
  }
  Subscription(const Subscription&) = delete;
  Subscription& operator=(const Subscription&) = delete;

  const std::string& topic() const override { return state_->topic; }
  std::uint64_t receivedCount() const override { return state_->received; }
  // Samples discarded because the callback fell behind by more than the keep-last depth
  // (sensor topics; the DDS history would have replaced them the same way).
  std::uint64_t droppedCount() const { return state_->dropped; }
  int matchedCount() const override {
    eprosima::fastdds::dds::SubscriptionMatchedStatus status;
    reader_->get_subscription_matched_status(status);
    return status.current_count;
  }

 private:
  // The DDS thread that delivers a sample (the writer's own thread within a process, a
  // receive thread across processes) takes it at once, while it holds the reader's lock
  // anyway, into a reused MsgT, and hands it over in `ready`; the Executor's worker only
  // runs the callback. When the worker took the samples itself it contended for the
  // reader lock with the delivering thread and slept on it: under a burst it received a
  // fraction of the scans (docs/runtime.md).
  struct State {
    std::string topic;
    TopicKind kind = TopicKind::kSensor;
    Callback callback;
    Executor* executor = nullptr;
    std::size_t depth = 0;  // keep-last depth of `ready`; 0: keep all

    // Held by a delivering DDS thread from take to queue: two receive threads (e.g. shared
    // memory and UDP) delivering to one reader must not queue its samples out of order.
    std::mutex take_mutex;
    std::mutex queue_mutex;  // guards ready, spare, depth, drain_queued; held briefly
    std::deque<std::unique_ptr<MsgT>> ready;
    std::vector<std::unique_ptr<MsgT>> spare;  // reused samples: no allocation per message
    bool drain_queued = false;

    std::mutex callback_mutex;  // held while callbacks run, so the destructor waits
    bool closed = false;
    std::atomic<std::uint64_t> received{0};
    std::atomic<std::uint64_t> dropped{0};
  };
  static constexpr std::size_t kMaxSpare = 16;  // bounds the memory kept for reuse

  static void drain(const std::shared_ptr<State>& state) {
    std::lock_guard<std::mutex> callback_lock(state->callback_mutex);
    if (state->closed) return;
    std::deque<std::unique_ptr<MsgT>> batch;
    {
      std::lock_guard<std::mutex> lock(state->queue_mutex);
      state->drain_queued = false;  // later arrivals queue another drain
      batch.swap(state->ready);
    }
    for (auto& sample : batch) {
      ++state->received;
      try {
        state->callback(*sample);
      } catch (const std::exception& e) {
        common::logError(
            common::str("subscription on ", state->topic, ": callback failed: ", e.what()));
      }
    }
    std::lock_guard<std::mutex> lock(state->queue_mutex);
    for (auto& sample : batch) {
      if (state->spare.size() >= kMaxSpare) break;
      state->spare.push_back(std::move(sample));
    }
  }

  class Listener : public eprosima::fastdds::dds::DataReaderListener {
   public:
    explicit Listener(std::weak_ptr<State> state) : state_(std::move(state)) {}
    void on_data_available(eprosima::fastdds::dds::DataReader* reader) override {
      auto state = state_.lock();
      if (!state) return;
      eprosima::fastdds::dds::SampleInfo info;
      bool post = false;
      std::lock_guard<std::mutex> take_lock(state->take_mutex);
      for (;;) {
        std::unique_ptr<MsgT> sample;
        {
          std::lock_guard<std::mutex> lock(state->queue_mutex);
          if (!state->spare.empty()) {
            sample = std::move(state->spare.back());
            state->spare.pop_back();
          }
        }
        if (!sample) sample = std::make_unique<MsgT>();
        if (reader->take_next_sample(sample.get(), &info) != ReturnCode_t::RETCODE_OK) {
          std::lock_guard<std::mutex> lock(state->queue_mutex);
          if (state->spare.size() < kMaxSpare) state->spare.push_back(std::move(sample));
          break;
        }
        if (!info.valid_data) continue;
        std::lock_guard<std::mutex> lock(state->queue_mutex);
        state->ready.push_back(std::move(sample));
        if (state->depth > 0 && state->ready.size() > state->depth) {
          // Keep last: the oldest waiting sample gives way, as in the DDS history.
          if (state->spare.size() < kMaxSpare) {
            state->spare.push_back(std::move(state->ready.front()));
          }
          state->ready.pop_front();
          ++state->dropped;
        }
        if (!state->drain_queued) post = state->drain_queued = true;
      }
      if (!post) return;
      std::weak_ptr<State> weak = state;
      state->executor->post([weak] {
        if (auto s = weak.lock()) drain(s);
      });
    }

    // Logged (debug) so a process that takes no sample shows whether it matched a writer.
    // A robot's sensor topic has one writer, its driver or replay: a second one (another
    // replay or robot on this domain, under the same robot name) mixes two streams, so it
    // is a warning.
    void on_subscription_matched(eprosima::fastdds::dds::DataReader*,
                                 const eprosima::fastdds::dds::SubscriptionMatchedStatus& status) override {
      auto state = state_.lock();
      if (!state) return;
      common::logDebug(common::str("dds: reader on ", state->topic, ": ", status.current_count_change > 0 ? "matched" : "unmatched",
                                   " a writer, ", status.current_count, " now"));
      if (state->kind == TopicKind::kSensor && status.current_count_change > 0 &&
          status.current_count > 1) {
        common::logWarn(common::str(
            "sensor topic ", state->topic, " has ", status.current_count,
            " writers, where a robot's sensor topic has one: another replay or robot on this DDS "
            "domain under the same name (or a restarted driver whose old participant has "
            "not yet expired); their samples are mixed"));
      }
    }

   private:
    std::weak_ptr<State> state_;
  };

  Context& context_;
  std::shared_ptr<State> state_;
  std::unique_ptr<Listener> listener_;
  eprosima::fastdds::dds::DataReader* reader_ = nullptr;
};

}  // namespace storey::runtime
