#include "storey/floor_matcher/floor_matcher_component.h"

#include <algorithm>
#include <chrono>
#include <set>
#include <string>
#include <vector>

#include "storey/common/log.h"
#include "storey/floor_matcher/conversions.h"

namespace storey::floor_matcher {

using common::logInfo;
using common::logWarn;
using common::str;

FloorMatcherComponentOptions readFloorMatcherComponentOptions(const common::ConfigNode& node) {
  FloorMatcherComponentOptions o;
  o.floor_graph_topic = node.get<std::string>("floor_graph_topic", o.floor_graph_topic);
  o.constraint_topic = node.get<std::string>("constraint_topic", o.constraint_topic);
  o.building_state_topic = node.get<std::string>("building_state_topic", o.building_state_topic);
  o.trigger.min_new_nodes = node.getInt("min_new_nodes", o.trigger.min_new_nodes, 1, 1000000);
  o.trigger.min_growth = node.getDouble("min_growth", o.trigger.min_growth, 0.0, 100.0);
  o.match_while_growing = node.get<bool>("match_while_growing", o.match_while_growing);
  o.trigger.min_nodes = node.getInt("min_nodes", o.trigger.min_nodes, 1, 1000000);
  o.match_after_idle = node.getDouble("match_after_idle", o.match_after_idle, 0.0, 3600.0);
  o.confirm_while_growing = node.get<bool>("confirm_while_growing", o.confirm_while_growing);
  // The same section `storey match --config` reads, so one file serves both.
  if (node.has("floor_matcher"))
    o.matcher = matching::readFloorMatcherOptions(node.child("floor_matcher"));
  if (node.has("retraction")) o.retraction = matching::readRetractionOptions(node.child("retraction"));
  node.finish();
  return o;
}

FloorMatcherComponent::FloorMatcherComponent(runtime::Context& context,
                                             const common::ConfigNode& parameters, std::string name)
    : runtime::Component(context, parameters, std::move(name)) {}

FloorMatcherComponent::~FloorMatcherComponent() { stopWorker(); }

void FloorMatcherComponent::onConfigure() {
  options_ = readFloorMatcherComponentOptions(parameters());
  publisher_ = createPublisher<storey_msgs::msg::InterFloorConstraint,
                               storey_msgs::msg::InterFloorConstraintPubSubType>(
      options_.constraint_topic, runtime::TopicKind::kGraph);
  createSubscription<storey_msgs::msg::FloorGraphUpdate,
                     storey_msgs::msg::FloorGraphUpdatePubSubType>(
      options_.floor_graph_topic, runtime::TopicKind::kGraph,
      [this](const storey_msgs::msg::FloorGraphUpdate& m) { onUpdate(m); });
  createSubscription<storey_msgs::msg::BuildingState, storey_msgs::msg::BuildingStatePubSubType>(
      options_.building_state_topic, runtime::TopicKind::kGraph,
      [this](const storey_msgs::msg::BuildingState& m) { onState(m); });
  if (options_.match_after_idle > 0)
    createTimer(std::min(0.25, options_.match_after_idle / 4), [this] { onIdleCheck(); });
}

bool FloorMatcherComponent::grewSinceMatched() const {
  for (const auto& [id, g] : graphs_) {
    auto it = matched_size_.find(id);
    if (g.nodes.size() >= static_cast<std::size_t>(options_.trigger.min_nodes) &&
        (it == matched_size_.end() || it->second != g.nodes.size()))
      return true;
  }
  return false;
}

void FloorMatcherComponent::onIdleCheck() {
  std::unique_lock<std::mutex> lock(mutex_);
  if (pending_ || busy_ || stop_) return;
  const double idle =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - last_update_).count();
  if (idle < options_.match_after_idle) return;
  if (grewSinceMatched()) {
    pending_ = true;
    settled_ = true;
    changed_.notify_all();
  } else {
    releaseHeldBack(lock);  // the last pass saw the graphs as they still are
  }
}

void FloorMatcherComponent::releaseHeldBack(std::unique_lock<std::mutex>& lock) {
  if (held_back_.empty()) return;
  std::vector<storey_msgs::msg::InterFloorConstraint> out;
  for (auto& [key, p] : held_back_) {
    if (published_.count(key)) continue;
    p.message.constraint_id(next_constraint_id_++);
    published_[key] = p;
    known_.insert(key);
    out.push_back(p.message);
  }
  held_back_.clear();
  stats_.constraints_published += out.size();
  auto publisher = publisher_;
  lock.unlock();
  for (const auto& m : out)
    if (publisher) publisher->publish(m);
  logInfo(str(name(), ": input settled: published ", out.size(), " constraints the last pass held back"));
  lock.lock();
}

void FloorMatcherComponent::onActivate() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stop_ = false;
  }
  worker_ = std::thread([this] { workerLoop(); });
}

// A pass in progress completes and publishes; no new pass starts.
void FloorMatcherComponent::onDeactivating() { stopWorker(); }
void FloorMatcherComponent::onDeactivate() { stopWorker(); }

void FloorMatcherComponent::onCleanup() {
  stopWorker();
  publisher_.reset();
}

void FloorMatcherComponent::stopWorker() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stop_ = true;
  }
  changed_.notify_all();
  if (worker_.joinable()) worker_.join();
}

FloorMatcherStats FloorMatcherComponent::stats() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return stats_;
}

bool FloorMatcherComponent::grewEnough(const floor::FloorGraph& g) const {
  const auto it = matched_size_.find(g.graph_id);
  return matching::grewEnoughToMatch(g.nodes.size(), it == matched_size_.end() ? nullptr : &it->second,
                                     options_.trigger);
}

void FloorMatcherComponent::onUpdate(const storey_msgs::msg::FloorGraphUpdate& message) {
  std::lock_guard<std::mutex> lock(mutex_);
  // A restarted mapper sends its updates again, in order: applying an old one twice would
  // duplicate its edges and put back its older poses.
  const auto key = std::make_pair(message.robot(), static_cast<int>(message.floor_graph_id()));
  const auto last = last_sequence_.find(key);
  if (last != last_sequence_.end() && message.sequence_number() <= last->second) {
    ++stats_.resent;
    return;
  }
  try {
    applyUpdate(message, &graphs_);  // conversion only: matching runs on the worker
    last_sequence_[key] = message.sequence_number();
    last_update_ = std::chrono::steady_clock::now();
    ++stats_.updates_accepted;
  } catch (const std::exception& e) {
    ++stats_.rejected;
    logWarn(str(name(), ": update rejected: ", e.what()));
    return;
  }
  if (options_.match_while_growing && grewEnough(graphs_.at(static_cast<int>(message.floor_graph_id())))) {
    pending_ = true;
    changed_.notify_all();
  }
}

void FloorMatcherComponent::onState(const storey_msgs::msg::BuildingState& message) {
  std::lock_guard<std::mutex> lock(mutex_);
  server_held_ = message.constraints();
  ++stats_.states_received;
}

void FloorMatcherComponent::workerLoop() {
  std::unique_lock<std::mutex> lock(mutex_);
  while (true) {
    changed_.wait(lock, [this] { return stop_ || pending_; });
    if (stop_) return;
    matchOnce(lock);
    // A flush waits for the pass, whichever way it ended (a one-floor building matches
    // nothing and returns early).
    changed_.notify_all();
  }
}

matching::MatchResult FloorMatcherComponent::match(const std::vector<floor::FloorGraph>& graphs,
                                                   const matching::FloorMatcherOptions& options) {
  return matching::matchFloors(graphs, options);
}

void FloorMatcherComponent::adoptServerHeld() {
  for (const auto& m : server_held_) {
    const auto key = std::make_tuple(static_cast<int>(m.from_floor_graph()), static_cast<int>(m.from_node()),
                                     static_cast<int>(m.to_floor_graph()), static_cast<int>(m.to_node()));
    if (!known_.insert(key).second) continue;  // most passes: every one known
    published_[key] = {constraintFromMessage(m), m};
    ++stats_.constraints_adopted;
  }
}

std::vector<storey_msgs::msg::InterFloorConstraint> FloorMatcherComponent::retractStale(
    const std::vector<floor::FloorGraph>& graphs, const matching::MatchResult& result,
    const matching::GrowthPassConfirmation* confirmation, std::vector<std::string>* reasons) {
  std::vector<matching::InterFloorConstraint> standing;
  std::vector<std::tuple<int, int, int, int>> keys;
  for (const auto& [key, p] : published_) {
    keys.push_back(key);
    standing.push_back(p.constraint);
  }
  std::vector<storey_msgs::msg::InterFloorConstraint> out;
  for (const auto& r : matching::constraintsToRetract(standing, graphs, result, options_.retraction,
                                                      confirmation)) {
    storey_msgs::msg::InterFloorConstraint m = published_.at(keys[r.index]).message;
    m.retracted(true);
    m.reason(r.reason);
    out.push_back(m);
    reasons->push_back(r.reason);
    published_.erase(keys[r.index]);
  }
  return out;
}

void FloorMatcherComponent::matchOnce(std::unique_lock<std::mutex>& lock) {
  pending_ = false;
  const bool settled = settled_;
  settled_ = false;
  std::vector<floor::FloorGraph> graphs;
  for (const auto& [id, g] : graphs_)
    if (g.nodes.size() >= static_cast<std::size_t>(options_.trigger.min_nodes)) graphs.push_back(g);
  for (const auto& g : graphs) matched_size_[g.graph_id] = g.nodes.size();
  if (graphs.size() < 2) {
    logInfo(str(name(), ": matched ", graphs.size(), " floor graphs: fewer than two have ", options_.trigger.min_nodes,
                " nodes"));
    return;
  }
  busy_ = true;
  const matching::FloorMatcherOptions matcher = options_.matcher;
  lock.unlock();
  matching::MatchResult result;
  bool matched = false;
  try {
    result = match(graphs, matcher);
    matched = true;
  } catch (const std::exception& e) {
    logWarn(str(name(), ": matching failed: ", e.what()));
  }
  std::vector<storey_msgs::msg::InterFloorConstraint> out;
  std::vector<std::string> retraction_notes;
  lock.lock();
  ++stats_.matchings;
  const matching::GrowthPassConfirmation confirmation(
      graphs, result, placement_history_, options_.retraction, options_.matcher.floor_change);
  const bool growing = options_.confirm_while_growing && !settled;
  if (matched) {
    adoptServerHeld();
    out = retractStale(graphs, result, growing ? &confirmation : nullptr, &retraction_notes);
  }
  const std::size_t retracted = out.size();
  std::size_t unconfirmed = 0;
  held_back_.clear();                     // this pass's verdict replaces the last one's
  std::set<std::string> held_back_notes;  // why graphs' constraints wait, once each
  if (growing)
    for (const auto& [graph, why] : confirmation.atOddsWithTransits()) held_back_notes.insert(why);
  for (const auto& c : result.constraints) {
    const auto key =
        std::make_tuple(c.reference_graph_id, c.reference_node_id, c.graph_id, c.node_id);
    if (published_.count(key)) continue;
    // A pass on growing graphs publishes only what an earlier pass, on less of the pair's
    // graphs, placed the same way (and where the robots' floor changes allow): a partial
    // floor can look like somewhere else until the robot sees more of it.
    const bool confirmed = !options_.confirm_while_growing || settled || confirmation.confirms(c);
    const matching::PairResult* pair = result.pairFor(c.graph_id);
    std::uint32_t support = 0;
    double l_min = 0.0;
    if (pair) {
      l_min = pair->l_min;
      for (const auto& cand : pair->candidates)
        support += cand.status == matching::CandidateStatus::kAccepted;
    }
    if (!confirmed) {
      ++unconfirmed;
      held_back_.push_back({key, {c, toMessage(c, 0, l_min, support)}});  // id given when released
      continue;
    }
    out.push_back(toMessage(c, next_constraint_id_++, l_min, support));
    published_[key] = {c, out.back()};
    known_.insert(key);
  }
  stats_.constraints_published += out.size() - retracted;
  stats_.constraints_retracted += retracted;
  stats_.constraints_unconfirmed += unconfirmed;
  if (matched) placement_history_.record(graphs, result);
  auto publisher = publisher_;
  lock.unlock();
  for (const auto& m : out)
    if (publisher) publisher->publish(m);
  for (const auto& why : retraction_notes) logInfo(str(name(), ": retracted a constraint: ", why));
  for (const auto& why : held_back_notes) logInfo(str(name(), ": held back: ", why));
  // Logged every time: a deployment's operator (and the fault tests) see when it ran.
  logInfo(str(name(), ": matched ", graphs.size(), " floor graphs: ", result.constraints.size(),
              " constraints, ", out.size() - retracted, " new, published, ", retracted, " retracted, ", unconfirmed,
              " held back unconfirmed (",
              result.seconds, " s)"));
  lock.lock();
  busy_ = false;
}

bool FloorMatcherComponent::flush(double timeout_s) {
  std::unique_lock<std::mutex> lock(mutex_);
  if (grewSinceMatched()) pending_ = true;
  if (pending_) settled_ = true;
  if (pending_ && stop_) matchOnce(lock);  // not active: match here
  changed_.notify_all();
  const bool done =
      changed_.wait_for(lock, std::chrono::duration<double>(timeout_s), [this] { return !pending_ && !busy_; });
  // What the last pass (on growing graphs) held back: it saw the graphs as they still are.
  if (done) releaseHeldBack(lock);
  return done;
}

}  // namespace storey::floor_matcher
