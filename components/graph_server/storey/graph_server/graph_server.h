// graph_server: keeps the building graph (every floor graph and inter-floor constraint,
// less those the matcher retracted), journals what it accepts, optimises on a worker thread
// (rate-limited, never on a DDS or executor callback), and publishes the building state, per-floor
// occupancy grids, the robots' live outputs and the building graph as markers.
#pragma once

#include <condition_variable>
#include <map>
#include <memory>
#include <mutex>
#include <thread>

#include "geometry_msgs/msg/PoseStampedPubSubTypes.h"
#include "nav_msgs/msg/OccupancyGridPubSubTypes.h"
#include "std_msgs/msg/Int32PubSubTypes.h"
#include "storey/building/building_graph.h"
#include "storey/building/building_outputs.h"
#include "storey/building/journal.h"
#include "storey/building/redelivery.h"
#include "storey/building/robot_locations.h"
#include "storey/common/shipped_config.h"
#include "storey/runtime/component.h"
#include "storey_msgs/msg/BuildingStatePubSubTypes.h"
#include "storey_msgs/msg/FloorGraphUpdatePubSubTypes.h"
#include "storey_msgs/msg/InterFloorConstraintPubSubTypes.h"
#include "tf2_msgs/msg/TFMessagePubSubTypes.h"
#include "visualization_msgs/msg/MarkerArrayPubSubTypes.h"

namespace storey::graph_server {

// The per-floor maps' grid: its resolution from the shipped file, the rest the grid's own.
grid::OccupancyGridOptions shippedFloorMaps();

struct GraphServerOptions {
  std::string floor_graph_topic = shipped::graph_server::floor_graph_topic;
  std::string constraint_topic = shipped::graph_server::constraint_topic;
  std::string building_state_topic = shipped::graph_server::building_state_topic;
  // + "/floor_<id>"
  std::string floor_map_topic_prefix = shipped::graph_server::floor_map_topic_prefix;
  // visualization_msgs/MarkerArray
  std::string markers_topic = shipped::graph_server::markers_topic;
  // empty: no journal
  std::string journal_path = shipped::graph_server::journal;
  // group commit before each published state
  bool journal_sync = shipped::graph_server::journal_sync;
  // seconds between optimisations
  double optimize_min_period = shipped::graph_server::optimize_min_period;
  bool publish_maps = shipped::graph_server::publish_maps;
  // key: map.resolution
  grid::OccupancyGridOptions map = shippedFloorMaps();
  building::BuildingGraphOptions building;
};
GraphServerOptions readGraphServerOptions(const common::ConfigNode& node);

struct GraphServerStats {
  std::uint64_t updates_accepted = 0;
  std::uint64_t constraints_accepted = 0;
  // Withdrawn by the matcher (held, or still waiting for their floor graphs).
  std::uint64_t constraints_retracted = 0;
  std::uint64_t rejected = 0;
  std::uint64_t optimisations = 0;
  std::uint64_t replayed_from_journal = 0;
  // Already held (a restarted server gets its publishers' whole history again; a
  // restarted matcher re-publishes what it finds again): ignored, not journalled.
  std::uint64_t duplicates_ignored = 0;
  // fdatasync calls on the journal: one per batch of accepted records (journal_sync).
  std::uint64_t journal_syncs = 0;
};

class GraphServer : public runtime::Component {
 public:
  GraphServer(runtime::Context& context, const common::ConfigNode& parameters, std::string name);
  ~GraphServer() override;

  // Blocks until everything accepted so far is optimised and published (or timeout).
  bool waitOptimized(double timeout_s);
  bool flush(double timeout_s) override { return waitOptimized(timeout_s); }
  // A copy of the building graph and its last solution (consistent with each other).
  std::pair<building::BuildingGraph, building::BuildingSolution> snapshot() const;
  GraphServerStats stats() const;

 protected:
  void onConfigure() override;
  void onActivate() override;
  void onDeactivating() override;
  void onDeactivate() override;
  void onCleanup() override;

 private:
  void onFloorGraph(const storey_msgs::msg::FloorGraphUpdate& message);
  void onConstraint(const storey_msgs::msg::InterFloorConstraint& message);
  void accept(const building::JournalRecord& record);
  void workerLoop();
  void stopWorker();
  void syncJournal();  // under mutex_
  // Per robot, as a ROS 2 robot expects them (REP 105), each keeping its last sample:
  // /tf building -> <robot>/odom, /<robot>/pose (building frame, z the floor's height),
  // /<robot>/floor (the floor id) and /<robot>/map (the map of the floor it is on).
  void publishRobotOutputs(const std::vector<building::RobotLocation>& locations,
                           const std::map<int, nav_msgs::msg::OccupancyGrid>& maps);
  struct RobotPublishers {
    std::shared_ptr<runtime::Publisher<geometry_msgs::msg::PoseStamped,
                                       geometry_msgs::msg::PoseStampedPubSubType>>
        pose;
    std::shared_ptr<runtime::Publisher<std_msgs::msg::Int32, std_msgs::msg::Int32PubSubType>> floor;
    std::shared_ptr<
        runtime::Publisher<nav_msgs::msg::OccupancyGrid, nav_msgs::msg::OccupancyGridPubSubType>>
        map;
  };
  std::map<std::string, RobotPublishers> robot_publishers_;
  std::shared_ptr<runtime::Publisher<tf2_msgs::msg::TFMessage, tf2_msgs::msg::TFMessagePubSubType>>
      tf_publisher_;

  GraphServerOptions options_;
  std::unique_ptr<building::JournalWriter> journal_;
  std::shared_ptr<runtime::Publisher<storey_msgs::msg::BuildingState, storey_msgs::msg::BuildingStatePubSubType>>
      state_publisher_;
  // The building graph for RViz and Foxglove, its last array kept for late subscribers.
  std::shared_ptr<runtime::Publisher<visualization_msgs::msg::MarkerArray,
                                     visualization_msgs::msg::MarkerArrayPubSubType>>
      markers_publisher_;
  std::map<int, std::shared_ptr<runtime::Publisher<nav_msgs::msg::OccupancyGrid, nav_msgs::msg::OccupancyGridPubSubType>>>
      map_publishers_;

  mutable std::mutex mutex_;
  std::condition_variable changed_;
  building::BuildingGraph building_;
  building::RedeliveryFilter redelivery_;  // what was accepted before and comes again
  building::BuildingSolution solution_;
  std::vector<building::InterGraphConstraint> pending_constraints_;  // waiting for their graphs
  std::uint64_t accepted_generation_ = 0;
  std::uint64_t optimized_generation_ = 0;
  GraphServerStats stats_;
  bool stop_ = false;
  std::thread worker_;
  std::uint32_t state_sequence_ = 0;
};

}  // namespace storey::graph_server
