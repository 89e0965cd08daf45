// Writes a mapped building into a folder: per-floor maps in the building frame (nav2
// map_server PGM+YAML and PNG), building.yaml, the merged graph (graph.g2o), the
// optimised trajectory (trajectory.csv, read by `storey evaluate`), the OctoMap
// (building.bt), pictures, and report.html with the figures.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "storey/building/building_graph.h"
#include "storey/building/building_outputs.h"
#include "storey/eval/metrics.h"
#include "storey/tools/report_timeline.h"

namespace storey::tools {

// What storey map and storey export accept for the outputs (metres): a finer floor map or
// OctoMap of a building would not fit in memory, a coarser one shows nothing.
inline constexpr double kMapResolutionRange[2] = {0.005, 5.0};
inline constexpr double kVoxelRange[2] = {0.01, 5.0};
inline constexpr double kWallHeightRange[2] = {0.1, 100.0};

struct BuildingOutputOptions {
  grid::OccupancyGridOptions map;
  building::OctomapOptions octomap;
};

struct Timing {
  std::string phase;
  double seconds = 0.0;
};

struct ReportExtras {
  std::string title = "storey building";
  std::string input;                       // what was mapped
  std::vector<Timing> timings;
  std::optional<eval::Evaluation> evaluation;           // with inter-floor constraints
  std::optional<eval::Evaluation> evaluation_unaligned;  // same graphs, no inter-floor constraints
  // solveWithoutConstraints(graph) when the caller has it already; computed when absent.
  std::optional<building::BuildingSolution> unaligned;
  double recording_seconds = 0.0;          // for the real-time factor
  // The floor detectors' TransitEnded events; absent when they are not known (a journal
  // holds no floor events).
  std::optional<RobotRides> rides;
  std::vector<std::string> notes;
  // What the summary flags for a person besides unplaced floor graphs (a robot's scans
  // mostly not mapped, a journal repaired).
  std::vector<std::string> warnings;
};

struct BuildingOutputSummary {
  std::vector<std::string> files;
  std::size_t occupied_voxels = 0;
  std::size_t floors = 0;
  std::size_t constraints = 0;
};

// Optimises nothing: writes what `solution` says. Throws std::runtime_error naming the
// file that could not be written.
BuildingOutputSummary writeBuildingOutputs(const std::string& dir, const building::BuildingGraph& graph,
                                           const building::BuildingSolution& solution,
                                           const BuildingOutputOptions& options, const ReportExtras& extras);

// A number for people, in the report and the experiment tables: fixed notation with
// `decimals` places, never an exponent, no minus sign on a zero, "-" when not finite.
std::string fixedText(double value, int decimals);

// Text for HTML: <, > and & escaped.
std::string htmlText(const std::string& text);

// The optimised node poses as trajectory rows (building frame; floor = floor id).
std::vector<eval::PoseRow> trajectoryRows(const building::BuildingGraph& graph,
                                          const building::BuildingSolution& solution);

// The same floor graphs without inter-floor constraints (each floor in its own frame):
// the "before" of the report and of `storey evaluate`'s comparison.
building::BuildingSolution solveWithoutConstraints(const building::BuildingGraph& graph);

// Draws the nodes and edges of the solution (inter-floor edges in red), one colour per floor.
grid::Image renderGraph(const building::BuildingGraph& graph, const building::BuildingSolution& solution,
                        bool draw_constraints);

}  // namespace storey::tools
