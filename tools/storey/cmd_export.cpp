// storey export JOURNAL OUTDIR: re-creates a building's outputs from a graph server journal.
#include <iostream>

#include "args.h"
#include "storey/building/journal.h"
#include "storey/tools/building_report.h"

namespace storey::cli {

extern const char* const summary_export = "write a building's maps, graph, OctoMap and report from a journal";

int run_export(Args& args) {
  args.usage("JOURNAL OUTDIR",
             "Rebuilds the building graph from a graph_server journal, optimises it and writes\n"
             "per-floor maps (PGM+YAML, PNG), building.yaml, graph.g2o, trajectory.csv,\n"
             "building.bt and report.html into OUTDIR.")
      .option("resolution", "M", "map resolution", "0.05")
      .option("voxel", "M", "OctoMap resolution", "0.1")
      .option("wall-height", "M", "height of the extruded walls in the OctoMap", "2.5");
  if (!args.parse()) return 0;
  const std::string journal_path = args.positional(0, "JOURNAL");
  const std::string out = args.positional(1, "OUTDIR");
  tools::BuildingOutputOptions options;
  options.map.resolution =
      args.getDouble("resolution", tools::kMapResolutionRange[0], tools::kMapResolutionRange[1]);
  options.octomap.resolution =
      args.getDouble("voxel", tools::kVoxelRange[0], tools::kVoxelRange[1]);
  options.octomap.wall_height =
      args.getDouble("wall-height", tools::kWallHeightRange[0], tools::kWallHeightRange[1]);
  building::JournalBuilding journal = building::rebuildFromJournal(journal_path);
  building::printJournalProblems(std::cerr, journal_path, journal);
  building::BuildingGraph& graph = journal.graph;
  const std::size_t skipped = journal.skipped.size();
  if (graph.empty()) throw std::runtime_error(journal_path + ": the journal holds no floor graph");
  const building::BuildingSolution solution = graph.optimize();
  tools::ReportExtras extras;
  extras.title = "storey building (from journal)";
  extras.input = journal_path;
  extras.warnings = building::journalProblems(journal_path, journal);
  const auto summary = tools::writeBuildingOutputs(out, graph, solution, options, extras);
  std::cout << "exported " << journal.records - skipped << " journal records: " << summary.floors
            << " floors, " << summary.constraints << " inter-floor constraints, " << summary.occupied_voxels
            << " occupied voxels\n";
  for (const auto& file : summary.files) std::cout << "  " << file << "\n";
  return skipped ? 1 : 0;
}

}  // namespace storey::cli
