// Typed publisher on a ROS 2-named topic. A publisher can be inactive (a lifecycle
// component's publishers are inactive until activate()): publish() then drops the message
// and counts it, so nothing leaves a component before activation.
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <string>
#include <thread>

#include "storey/common/log.h"
#include "storey/runtime/context.h"

namespace storey::runtime {

class PublisherBase {
 public:
  virtual ~PublisherBase() = default;
  void setActive(bool active) { active_ = active; }
  bool isActive() const { return active_; }
  std::uint64_t publishedCount() const { return published_; }
  std::uint64_t droppedInactiveCount() const { return dropped_inactive_; }
  const std::string& topic() const { return topic_; }
  // Number of matched subscriptions (DDS readers) right now.
  virtual int matchedCount() const = 0;
  // Waits until every matched reader acknowledged every sample (reliable topics; a best-
  // effort writer returns at once); false on timeout.
  virtual bool waitForAcknowledgments(double timeout_s) const = 0;
  // Waits until at least `count` readers matched; false on timeout.
  bool waitForSubscribers(int count, double timeout_s) const {
    const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
    while (matchedCount() < count) {
      if (std::chrono::steady_clock::now() > end) return false;
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    return true;
  }

 protected:
  PublisherBase(std::string topic, bool active) : topic_(std::move(topic)), active_(active) {}
  std::string topic_;
  std::atomic<bool> active_;
  std::atomic<std::uint64_t> published_{0};
  std::atomic<std::uint64_t> dropped_inactive_{0};
};

// MsgT: generated message class (sensor_msgs::msg::LaserScan); PubSubT: its
// generated PubSubType (sensor_msgs::msg::LaserScanPubSubType).
template <typename MsgT, typename PubSubT>
class Publisher : public PublisherBase {
 public:
  Publisher(Context& context, const std::string& topic, TopicKind kind, bool active = true)
      : PublisherBase(topic, active), context_(context) {
    writer_ = context_.createWriter<PubSubT>(topic, kind);
  }
  ~Publisher() override { context_.deleteWriter(writer_); }
  Publisher(const Publisher&) = delete;
  Publisher& operator=(const Publisher&) = delete;

  // Returns false when the message was not sent (inactive, or the writer refused it).
  bool publish(const MsgT& message) {
    if (!active_) {
      if (dropped_inactive_++ == 0) {
        common::logWarn(common::str("publisher on ", topic_, " is inactive: message dropped"));
      }
      return false;
    }
    // DataWriter::write takes a non-const pointer but does not modify the sample.
    if (!writer_->write(const_cast<MsgT*>(&message))) {
      common::logWarn(common::str("publisher on ", topic_, ": write failed"));
      return false;
    }
    ++published_;
    return true;
  }

  bool waitForAcknowledgments(double timeout_s) const override {
    const auto ns = static_cast<std::int64_t>(timeout_s * 1e9);
    const eprosima::fastrtps::Duration_t timeout(static_cast<std::int32_t>(ns / 1000000000),
                                                 static_cast<std::uint32_t>(ns % 1000000000));
    return writer_->wait_for_acknowledgments(timeout) == eprosima::fastrtps::types::ReturnCode_t::RETCODE_OK;
  }

  int matchedCount() const override {
    eprosima::fastdds::dds::PublicationMatchedStatus status;
    writer_->get_publication_matched_status(status);
    return status.current_count;
  }

 private:
  Context& context_;
  eprosima::fastdds::dds::DataWriter* writer_ = nullptr;
};

}  // namespace storey::runtime
