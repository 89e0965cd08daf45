// The floor_matcher component: subscribes to floor-graph updates, and when a floor graph is
// new or has grown enough, runs the floor matcher (storey::matching) on a worker thread,
// never on the DDS callback thread, and publishes each newly accepted inter-floor
// constraint with its evidence on a reliable, transient-local topic. A constraint once
// published is not published again (re-matching a grown graph may confirm it); one that a
// later pass no longer stands behind (matching::constraintsToRetract) is withdrawn by a
// message with `retracted` set, on the same topic so readers get the two in order.
#pragma once

#include <chrono>
#include <condition_variable>
#include <map>
#include <memory>
#include <mutex>
#include <set>
#include <string>
#include <thread>
#include <tuple>

#include "storey/common/config.h"
#include "storey/common/shipped_config.h"
#include "storey/floor/floor_graph.h"
#include "storey/matching/floor_matcher.h"
#include "storey/matching/growth_passes.h"
#include "storey/matching/retraction.h"
#include "storey/runtime/component.h"
#include "storey_msgs/msg/BuildingStatePubSubTypes.h"
#include "storey_msgs/msg/FloorGraphUpdatePubSubTypes.h"
#include "storey_msgs/msg/InterFloorConstraintPubSubTypes.h"

namespace storey::floor_matcher {

struct FloorMatcherComponentOptions {
  std::string floor_graph_topic = shipped::floor_matcher::floor_graph_topic;
  std::string constraint_topic = shipped::floor_matcher::constraint_topic;
  // The graph server's state lists the constraints it holds: a restarted matcher adopts
  // those it did not publish itself, so a later pass can withdraw them too.
  std::string building_state_topic = shipped::floor_matcher::building_state_topic;
  // Re-match when a graph of `min_nodes` or more is new or has grown by `min_new_nodes`
  // nodes and by `min_growth` (fraction of its size at the last matching): keys
  // min_nodes, min_new_nodes, min_growth.
  matching::GrowthTrigger trigger;
  // false: match only when flushed (storey map), so the result does not depend on when
  // updates arrived while the worker was busy.
  bool match_while_growing = shipped::floor_matcher::match_while_growing;
  // > 0: match once no floor-graph update has arrived for this long (s) and a graph grew
  // since its last matching, so a deployment matches the final graphs when input ends
  // (and a restarted matcher re-matches what its topic history gave it).
  double match_after_idle = shipped::floor_matcher::match_after_idle;
  // A pass triggered by growth publishes only constraints the pass before placed the same
  // way (within `retraction`'s tolerances); passes when input has settled (after
  // match_after_idle, or a flush) publish all they accept. Partial floors mislead: see
  // docs/floor_matcher.md, "Matching while the graphs grow".
  bool confirm_while_growing = shipped::floor_matcher::confirm_while_growing;
  matching::FloorMatcherOptions matcher;
  matching::RetractionOptions retraction;  // under `retraction:`
};
// Reads the component's parameters; the matcher's options are under `floor_matcher:` (as in config/floor_matcher.yaml and `storey match --config`).
FloorMatcherComponentOptions readFloorMatcherComponentOptions(const common::ConfigNode& node);

struct FloorMatcherStats {
  std::size_t updates_accepted = 0;
  std::size_t rejected = 0;
  std::size_t resent = 0;  // updates already applied (a restarted mapper sends them again)
  std::size_t matchings = 0;
  std::size_t constraints_published = 0;
  std::size_t constraints_retracted = 0;
  std::size_t constraints_unconfirmed = 0;  // accepted by a growth pass, held back
  std::size_t states_received = 0;          // building states from the graph server
  std::size_t constraints_adopted = 0;      // held by the server, published by someone else
};

class FloorMatcherComponent : public runtime::Component {
 public:
  FloorMatcherComponent(runtime::Context& context, const common::ConfigNode& parameters,
                        std::string name);
  ~FloorMatcherComponent() override;

  // Matches whatever has arrived and is not matched yet, then returns once published.
  bool flush(double timeout_s) override;
  FloorMatcherStats stats() const;

 protected:
  // One matching pass (matching::matchFloors); tests replace it to script what passes find.
  virtual matching::MatchResult match(const std::vector<floor::FloorGraph>& graphs,
                                      const matching::FloorMatcherOptions& options);
  void onConfigure() override;
  void onActivate() override;
  void onDeactivating() override;
  void onDeactivate() override;
  void onCleanup() override;

 private:
  void onUpdate(const storey_msgs::msg::FloorGraphUpdate& message);
  void onState(const storey_msgs::msg::BuildingState& message);
  bool grewEnough(const floor::FloorGraph& graph) const;  // caller holds mutex_
  bool grewSinceMatched() const;                          // caller holds mutex_
  void onIdleCheck();
  void workerLoop();
  void matchOnce(std::unique_lock<std::mutex>& lock);
  // (Callers hold mutex_.) The server's constraints this instance did not publish (its
  // predecessor's, before a restart) join published_, to be checked as its own.
  void adoptServerHeld();
  // Withdraws from published_ what `result` no longer stands behind (with `confirmation`,
  // a growth pass's: only what it may retract); returns the retraction messages to
  // publish, and each reason in `reasons`.
  std::vector<storey_msgs::msg::InterFloorConstraint> retractStale(
      const std::vector<floor::FloorGraph>& graphs, const matching::MatchResult& result,
      const matching::GrowthPassConfirmation* confirmation, std::vector<std::string>* reasons);
  // Publishes what the last pass held back unconfirmed (the graphs have not grown since).
  void releaseHeldBack(std::unique_lock<std::mutex>& lock);
  void stopWorker();

  FloorMatcherComponentOptions options_;
  std::shared_ptr<runtime::Publisher<storey_msgs::msg::InterFloorConstraint,
                                     storey_msgs::msg::InterFloorConstraintPubSubType>>
      publisher_;
  mutable std::mutex mutex_;
  std::condition_variable changed_;
  std::map<int, floor::FloorGraph> graphs_;
  std::map<int, std::size_t> matched_size_;  // graph id -> nodes at its last matching
  // Published and not retracted, by (reference graph, reference node, graph, node).
  struct Published {
    matching::InterFloorConstraint constraint;
    storey_msgs::msg::InterFloorConstraint message;
  };
  std::map<std::tuple<int, int, int, int>, Published> published_;
  // Every constraint this instance published or retracted: the server's others are adopted.
  std::set<std::tuple<int, int, int, int>> known_;
  std::vector<storey_msgs::msg::InterFloorConstraint> server_held_;  // the latest state's
  std::uint32_t next_constraint_id_ = 0;
  bool pending_ = false;
  bool settled_ = false;  // the pending pass was asked for by a flush or idle input
  matching::PlacementHistory placement_history_;
  std::vector<std::pair<std::tuple<int, int, int, int>, Published>> held_back_;  // by the last pass
  std::chrono::steady_clock::time_point last_update_;
  bool busy_ = false;
  bool stop_ = true;
  std::thread worker_;
  FloorMatcherStats stats_;
  std::map<std::pair<std::string, int>, std::uint32_t> last_sequence_;  // per (robot, floor graph)
};

}  // namespace storey::floor_matcher
