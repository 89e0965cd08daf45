#include "storey/graph_server/graph_server.h"

#include <algorithm>
#include <chrono>

#include "storey/common/log.h"
#include "storey/graph_server/conversions.h"

namespace storey::graph_server {

using common::logInfo;
using common::logWarn;
using common::str;

grid::OccupancyGridOptions shippedFloorMaps() {
  grid::OccupancyGridOptions o;
  o.resolution = shipped::graph_server::map::resolution;
  return o;
}

GraphServerOptions readGraphServerOptions(const common::ConfigNode& node) {
  GraphServerOptions o;
  o.floor_graph_topic = node.get<std::string>("floor_graph_topic", o.floor_graph_topic);
  o.constraint_topic = node.get<std::string>("constraint_topic", o.constraint_topic);
  o.building_state_topic = node.get<std::string>("building_state_topic", o.building_state_topic);
  o.floor_map_topic_prefix = node.get<std::string>("floor_map_topic_prefix", o.floor_map_topic_prefix);
  o.markers_topic = node.get<std::string>("markers_topic", o.markers_topic);
  o.journal_path = node.get<std::string>("journal", o.journal_path);
  o.journal_sync = node.get<bool>("journal_sync", o.journal_sync);
  o.optimize_min_period = node.getDouble("optimize_min_period", o.optimize_min_period, 0.0, 3600.0);
  o.publish_maps = node.get<bool>("publish_maps", o.publish_maps);
  if (node.has("map")) {
    const common::ConfigNode map = node.child("map");
    o.map.resolution = map.getDouble("resolution", o.map.resolution, 0.005, 10.0);
    map.finish();
  }
  if (node.has("building")) o.building = building::readBuildingGraphOptions(node.child("building"));
  node.finish();
  return o;
}

GraphServer::GraphServer(runtime::Context& context, const common::ConfigNode& parameters, std::string name)
    : runtime::Component(context, parameters, std::move(name)) {}

GraphServer::~GraphServer() { stopWorker(); }

void GraphServer::onConfigure() {
  options_ = readGraphServerOptions(parameters());
  building_ = building::BuildingGraph(options_.building);
  redelivery_ = {};
  if (!options_.journal_path.empty()) {
    journal_ = std::make_unique<building::JournalWriter>(options_.journal_path, options_.journal_sync);
    for (const auto& record : journal_->existing()) {
      try {
        redelivery_.noteAccepted(building_, record);
        building::applyRecord(building_, record);
        ++stats_.replayed_from_journal;
      } catch (const std::exception& e) {
        logWarn(str(name(), ": journal record not applied: ", e.what()));
      }
    }
    if (stats_.replayed_from_journal) {
      logInfo(str(name(), ": resumed ", stats_.replayed_from_journal, " records from ", options_.journal_path));
      ++accepted_generation_;  // optimise what was resumed
    }
  }
  state_publisher_ =
      createPublisher<storey_msgs::msg::BuildingState, storey_msgs::msg::BuildingStatePubSubType>(
          options_.building_state_topic, runtime::TopicKind::kGraph);
  markers_publisher_ = createPublisher<visualization_msgs::msg::MarkerArray,
                                       visualization_msgs::msg::MarkerArrayPubSubType>(
      options_.markers_topic, runtime::TopicKind::kLatest);
  createSubscription<storey_msgs::msg::FloorGraphUpdate, storey_msgs::msg::FloorGraphUpdatePubSubType>(
      options_.floor_graph_topic, runtime::TopicKind::kGraph,
      [this](const storey_msgs::msg::FloorGraphUpdate& m) { onFloorGraph(m); });
  createSubscription<storey_msgs::msg::InterFloorConstraint, storey_msgs::msg::InterFloorConstraintPubSubType>(
      options_.constraint_topic, runtime::TopicKind::kGraph,
      [this](const storey_msgs::msg::InterFloorConstraint& m) { onConstraint(m); });
}

void GraphServer::onActivate() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stop_ = false;
  }
  worker_ = std::thread([this] { workerLoop(); });
}

// An optimisation in progress completes and publishes its state; no new one starts.
void GraphServer::onDeactivating() { stopWorker(); }
void GraphServer::onDeactivate() { stopWorker(); }

void GraphServer::onCleanup() {
  stopWorker();
  journal_.reset();
  map_publishers_.clear();
  robot_publishers_.clear();
  tf_publisher_.reset();
  state_publisher_.reset();
}

// Group commit: the records accepted since the last sync become durable together.
void GraphServer::syncJournal() {
  if (!journal_) return;
  try {
    journal_->sync();
    stats_.journal_syncs = journal_->syncs();
  } catch (const std::exception& e) {
    logWarn(str(name(), ": ", e.what()));
  }
}

void GraphServer::stopWorker() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stop_ = true;
  }
  changed_.notify_all();
  if (worker_.joinable()) worker_.join();
  std::lock_guard<std::mutex> lock(mutex_);
  syncJournal();  // what was accepted is on disk when the server stops
}

namespace {

// True when applying `d` would change nothing (every node, edge and pose already held).
bool changesNothing(const building::BuildingGraph& building, const building::FloorGraphDelta& d) {
  auto it = building.floorGraphs().find(d.graph_id);
  if (it == building.floorGraphs().end()) return false;
  const floor::FloorGraph& g = it->second;
  if (g.robot != d.robot || g.floor_id != d.floor_id || g.floor_height != d.floor_height) return false;
  for (const auto& node : d.new_nodes)
    if (!g.findNode(node.id)) return false;
  for (const auto& edge : d.new_edges) {
    const bool held = std::any_of(g.edges.begin(), g.edges.end(), [&](const floor::FloorEdge& e) {
      return e.from == edge.from && e.to == edge.to && e.kind == edge.kind;
    });
    if (!held) return false;
  }
  for (const auto& [id, pose] : d.poses) {
    const floor::FloorNode* node = g.findNode(id);
    if (!node || !(node->pose.x() == pose.x() && node->pose.y() == pose.y() && node->pose.theta() == pose.theta()))
      return false;
  }
  return true;
}

// The same pair of nodes constrained again (matching is repeated; ids restart with the
// matcher).
bool holdsConstraint(const building::BuildingGraph& building, const building::InterGraphConstraint& c) {
  for (const auto& held : building.constraints())
    if (held.graph_from == c.graph_from && held.node_from == c.node_from && held.graph_to == c.graph_to &&
        held.node_to == c.node_to)
      return true;
  return false;
}

}  // namespace

void GraphServer::accept(const building::JournalRecord& record) {
  std::lock_guard<std::mutex> lock(mutex_);
  // Check, journal, then apply: a bad record changes nothing and is never journalled.
  if (const auto* d = std::get_if<building::FloorGraphDelta>(&record)) {
    building::checkDelta(building_, *d);
    if (redelivery_.isRedelivery(building_, record) || changesNothing(building_, *d)) {
      ++stats_.duplicates_ignored;
      return;
    }
    if (journal_) journal_->append(record);
    redelivery_.noteAccepted(building_, record);
    building::applyDelta(building_, *d);
    ++stats_.updates_accepted;
  } else if (const auto* r = std::get_if<building::ConstraintRetraction>(&record)) {
    const auto& held = building_.constraints();
    if (std::none_of(held.begin(), held.end(), [&](const auto& c) { return r->retracts(c); })) {
      // Not in the graph: it may still wait for its floor graphs, or was never held
      // (a restarted server that resumed after the retraction gets the history again).
      const auto before = pending_constraints_.size();
      pending_constraints_.erase(std::remove_if(pending_constraints_.begin(), pending_constraints_.end(),
                                                [&](const auto& c) { return r->retracts(c); }),
                                 pending_constraints_.end());
      if (pending_constraints_.size() == before) ++stats_.duplicates_ignored;
      else ++stats_.constraints_retracted;
      return;
    }
    if (journal_) journal_->append(record);
    redelivery_.noteAccepted(building_, record);
    building_.retractConstraint(*r);
    ++stats_.constraints_retracted;
    logInfo(str(name(), ": retracted the constraint graph ", r->graph_from, " node ", r->node_from, " -> graph ",
                r->graph_to, " node ", r->node_to, ": ", r->reason));
  } else {
    const auto& constraint = std::get<building::InterGraphConstraint>(record);
    if (holdsConstraint(building_, constraint) || redelivery_.isRedelivery(building_, record)) {
      ++stats_.duplicates_ignored;
      return;
    }
    building_.addConstraint(constraint);  // validates
    if (journal_) {
      try {
        journal_->append(record);
      } catch (...) {
        building_.removeLastConstraint();  // not durable, so not accepted
        throw;
      }
    }
    ++stats_.constraints_accepted;
  }
  ++accepted_generation_;
  changed_.notify_all();
}

void GraphServer::onFloorGraph(const storey_msgs::msg::FloorGraphUpdate& message) {
  try {
    accept(fromMessage(message));
    // Constraints that arrived before their floor graphs.
    std::vector<building::InterGraphConstraint> waiting;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      waiting.swap(pending_constraints_);
    }
    for (const auto& c : waiting) {
      try {
        accept(c);
      } catch (const std::invalid_argument&) {
        std::lock_guard<std::mutex> lock(mutex_);
        pending_constraints_.push_back(c);
      }
    }
  } catch (const std::exception& e) {
    std::lock_guard<std::mutex> lock(mutex_);
    ++stats_.rejected;
    logWarn(str(name(), ": rejected a floor-graph update from robot '", message.robot(), "': ", e.what()));
  }
}

void GraphServer::onConstraint(const storey_msgs::msg::InterFloorConstraint& message) {
  if (message.retracted()) {
    try {
      accept(retractionFromMessage(message));
    } catch (const std::exception& e) {  // the journal could not record it: still held
      std::lock_guard<std::mutex> lock(mutex_);
      ++stats_.rejected;
      logWarn(str(name(), ": retraction not applied: ", e.what()));
    }
    return;
  }
  const building::InterGraphConstraint c = fromMessage(message);
  try {
    accept(c);
  } catch (const std::invalid_argument& e) {
    std::lock_guard<std::mutex> lock(mutex_);
    const bool graphs_known = building_.floorGraphs().count(c.graph_from) && building_.floorGraphs().count(c.graph_to);
    if (graphs_known) {
      ++stats_.rejected;
      logWarn(str(name(), ": rejected ", e.what()));
    } else {
      pending_constraints_.push_back(c);  // its floor graph is still on its way
    }
  }
}

void GraphServer::workerLoop() {
  auto last = std::chrono::steady_clock::now() - std::chrono::hours(1);
  while (true) {
    building::BuildingGraph work;
    std::uint64_t generation;
    {
      std::unique_lock<std::mutex> lock(mutex_);
      changed_.wait(lock, [&] { return stop_ || accepted_generation_ != optimized_generation_; });
      if (stop_) return;
      // Rate limit: gather what arrives within the period into one optimisation.
      const auto next = last + std::chrono::duration<double>(options_.optimize_min_period);
      if (changed_.wait_until(lock, next, [&] { return stop_; })) return;
      syncJournal();  // what the state below reflects is on disk first
      work = building_;
      generation = accepted_generation_;
    }
    last = std::chrono::steady_clock::now();
    building::BuildingSolution solution;
    try {
      solution = work.optimize();
    } catch (const std::exception& e) {
      logWarn(str(name(), ": optimisation failed: ", e.what()));
      std::lock_guard<std::mutex> lock(mutex_);
      optimized_generation_ = generation;
      changed_.notify_all();
      continue;
    }
    const double stamp = std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
    state_publisher_->publish(toMessage(solution, work.constraints(), state_sequence_++, stamp));
    // Each floor's grid converted once: its floor topic and every robot on it share it.
    std::map<int, nav_msgs::msg::OccupancyGrid> maps;
    if (options_.publish_maps) {
      try {
        for (const auto& [floor_id, floor] :
             building::renderBuildingFloors(work, solution, options_.map)) {
          auto& publisher = map_publishers_[floor_id];
          if (!publisher)
            publisher = createPublisher<nav_msgs::msg::OccupancyGrid,
                                        nav_msgs::msg::OccupancyGridPubSubType>(
                options_.floor_map_topic_prefix + "/floor_" + std::to_string(floor_id),
                runtime::TopicKind::kGraph);
          publisher->publish(maps[floor_id] = toMessage(floor, stamp));
        }
      } catch (const std::exception& e) {  // a map too large to draw: the state went out
        logWarn(str(name(), ": floor maps not published: ", e.what()));
      }
    }
    publishRobotOutputs(building::robotLocations(work, solution), maps);
    markers_publisher_->publish(toMessage(building::buildingMarkers(work, solution), stamp));
    std::lock_guard<std::mutex> lock(mutex_);
    solution_ = solution;
    optimized_generation_ = generation;
    ++stats_.optimisations;
    changed_.notify_all();
  }
}

bool GraphServer::waitOptimized(double timeout_s) {
  std::unique_lock<std::mutex> lock(mutex_);
  return changed_.wait_for(lock, std::chrono::duration<double>(timeout_s),
                           [&] { return optimized_generation_ == accepted_generation_; });
}

std::pair<building::BuildingGraph, building::BuildingSolution> GraphServer::snapshot() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return {building_, solution_};
}

GraphServerStats GraphServer::stats() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return stats_;
}

}  // namespace storey::graph_server
