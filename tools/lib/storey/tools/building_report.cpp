#include "storey/tools/building_report.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <map>
#include <sstream>

#include "storey/building/building_scene.h"
#include "storey/building/building_summary.h"
#include "storey/building/isometric_view.h"
#include "storey/eval/trajectory.h"
#include "storey/graph/graph_io.h"
#include "storey/grid/image.h"
#include "storey/tools/report_view.h"

namespace storey::tools {
namespace fs = std::filesystem;

namespace {

// The building graph's node ids are BuildingGraph::globalId(floor-graph id, node id), and
// floor-graph ids are spread out per robot (floor_mapper first_floor_graph_id): far beyond
// the 32-bit vertex ids g2o tools read. The file numbers the floor graphs by rank instead
// (the order of building.yaml's floor_graphs).
graph::PoseGraph withRankedGraphIds(const graph::PoseGraph& graph) {
  constexpr graph::NodeId kStride = building::BuildingGraph::kGraphIdStride;
  std::map<graph::NodeId, graph::NodeId> rank;
  for (const auto& node : graph.nodes()) rank.emplace(node.id / kStride, 0);
  graph::NodeId next = 0;
  for (auto& [floor_graph, r] : rank) r = next++;
  auto renumber = [&](graph::NodeId id) { return rank.at(id / kStride) * kStride + id % kStride; };
  graph::PoseGraph out;
  for (auto node : graph.nodes()) {
    node.id = renumber(node.id);
    out.addNode(node);
  }
  for (auto edge : graph.edges()) {
    edge.from = renumber(edge.from);
    edge.to = renumber(edge.to);
    out.addEdge(edge);
  }
  return out;
}

}  // namespace

std::string htmlText(const std::string& text) {
  std::string out;
  for (char c : text) {
    if (c == '<') out += "&lt;";
    else if (c == '>') out += "&gt;";
    else if (c == '&') out += "&amp;";
    else out += c;
  }
  return out;
}

// A number for people: fixed notation with `decimals` places (millimetres for metres, hundredths
// for degrees), never an exponent, and no minus sign on a zero.
std::string fixedText(double value, int decimals) {
  if (!std::isfinite(value)) return "-";
  std::ostringstream text;
  text << std::fixed << std::setprecision(decimals) << value;
  std::string s = text.str();
  if (s.find_first_not_of("-0.") == std::string::npos && s.front() == '-') s.erase(0, 1);
  return s;
}

std::vector<eval::PoseRow> trajectoryRows(const building::BuildingGraph& graph,
                                          const building::BuildingSolution& solution) {
  std::vector<eval::PoseRow> rows;
  for (const auto& [g, fg] : graph.floorGraphs())
    for (const auto& node : fg.nodes) {
      auto pose = solution.poses.find({g, node.id});
      eval::PoseRow row;
      row.stamp = node.stamp;
      row.robot = fg.robot;
      row.floor = std::to_string(fg.floor_id);
      row.pose = pose == solution.poses.end() ? node.pose : pose->second;
      row.z = fg.floor_height;
      rows.push_back(row);
    }
  std::sort(rows.begin(), rows.end(), [](const eval::PoseRow& a, const eval::PoseRow& b) {
    return a.robot != b.robot ? a.robot < b.robot : a.stamp < b.stamp;
  });
  return rows;
}

building::BuildingSolution solveWithoutConstraints(const building::BuildingGraph& graph) {
  building::BuildingGraph alone;
  for (const auto& [g, fg] : graph.floorGraphs()) alone.upsertFloorGraph(fg);
  return alone.optimize();
}

grid::Image renderGraph(const building::BuildingGraph& graph, const building::BuildingSolution& solution,
                        bool draw_constraints) {
  double min_x = 1e300, min_y = 1e300, max_x = -1e300, max_y = -1e300;
  for (const auto& [key, pose] : solution.poses) {
    min_x = std::min(min_x, pose.x());
    min_y = std::min(min_y, pose.y());
    max_x = std::max(max_x, pose.x());
    max_y = std::max(max_y, pose.y());
  }
  if (solution.poses.empty()) return grid::Image(1, 1, 3);
  const double span = std::max({max_x - min_x, max_y - min_y, 1.0});
  const double scale = 760.0 / span;
  const int w = static_cast<int>((max_x - min_x) * scale) + 41, h = static_cast<int>((max_y - min_y) * scale) + 41;
  grid::Image image(w, h, 3, 255);
  auto pixel = [&](const geometry::Pose2& p) {
    return std::pair<int, int>{static_cast<int>((p.x() - min_x) * scale) + 20,
                               h - 1 - (static_cast<int>((p.y() - min_y) * scale) + 20)};
  };
  std::map<int, int> colour_of_floor;
  for (const auto& [g, fg] : graph.floorGraphs()) {
    if (!colour_of_floor.count(fg.floor_id)) {
      const int next = static_cast<int>(colour_of_floor.size());
      colour_of_floor[fg.floor_id] = next;
    }
    const auto colour = building::floorColour(static_cast<std::size_t>(colour_of_floor[fg.floor_id]));
    for (const auto& edge : fg.edges) {
      auto a = solution.poses.find({g, edge.from}), b = solution.poses.find({g, edge.to});
      if (a == solution.poses.end() || b == solution.poses.end()) continue;
      const auto [x0, y0] = pixel(a->second);
      const auto [x1, y1] = pixel(b->second);
      grid::drawLine(image, x0, y0, x1, y1, colour);
    }
  }
  if (draw_constraints)
    for (const auto& c : graph.constraints()) {
      auto a = solution.poses.find({c.graph_from, c.node_from}), b = solution.poses.find({c.graph_to, c.node_to});
      if (a == solution.poses.end() || b == solution.poses.end()) continue;
      const auto [x0, y0] = pixel(a->second);
      const auto [x1, y1] = pixel(b->second);
      grid::drawLine(image, x0, y0, x1, y1, {0, 0, 0});
    }
  return image;
}

namespace {

// The first screen: what was mapped, whether the constraints placed every floor graph,
// which floors to look at, and the accuracy when there is ground truth.
void writeSummary(std::ostream& out, const building::BuildingGraph& graph,
                  const building::BuildingSolution& solution, const ReportExtras& extras) {
  const building::BuildingSummary s = building::summarizeBuilding(graph, solution);
  out << "<h2>Summary</h2>\n<ul>\n<li>" << s.floors << (s.floors == 1 ? " floor, " : " floors, ")
      << s.robots << (s.robots == 1 ? " robot, " : " robots, ") << s.graphs
      << (s.graphs == 1 ? " floor graph" : " floor graphs");
  if (extras.recording_seconds > 0)
    out << ", " << fixedText(extras.recording_seconds / 60.0, 1) << " min of recording";
  out << "</li>\n<li>" << s.constraints << " inter-floor constraints; ";
  if (s.floors_to_check.empty()) {
    out << "<b>every floor graph is placed by them</b>";
  } else {
    out << "<b>" << s.graphs - s.aligned_graphs << " of " << s.graphs
        << " floor graphs not placed by them: check floor";
    for (std::size_t i = 0; i < s.floors_to_check.size(); ++i)
      out << (i == 0 ? (s.floors_to_check.size() > 1 ? "s " : " ") : ", ") << s.floors_to_check[i];
    out << "</b>";
  }
  out << "</li>\n";
  for (const std::string& w : s.warnings) out << "<li class=\"warn\">" << htmlText(w) << "</li>\n";
  for (const std::string& w : extras.warnings)
    out << "<li class=\"warn\">" << htmlText(w) << "</li>\n";
  if (extras.evaluation && !extras.evaluation->floors.empty()) {
    const eval::FloorError* worst = &extras.evaluation->floors.front();
    for (const auto& f : extras.evaluation->floors)
      if (f.residual_translation > worst->residual_translation) worst = &f;
    double worst_rotation = 0.0;
    for (const auto& f : extras.evaluation->floors)
      worst_rotation = std::max(worst_rotation, std::abs(f.residual_rotation));
    out << "<li>Against ground truth: every floor within "
        << fixedText(worst->residual_translation * 1000, 0) << " mm (floor "
        << htmlText(worst->floor) << ") and " << fixedText(worst_rotation * 180 / M_PI, 2)
        << "&deg;</li>\n";
  }
  out << "</ul>\n";
}

}  // namespace

BuildingOutputSummary writeBuildingOutputs(const std::string& dir, const building::BuildingGraph& graph,
                                           const building::BuildingSolution& solution,
                                           const BuildingOutputOptions& options, const ReportExtras& extras) {
  const auto outputs_start = std::chrono::steady_clock::now();
  fs::create_directories(dir);
  BuildingOutputSummary summary;
  auto add = [&](const std::string& name) { summary.files.push_back((fs::path(dir) / name).string()); };
  const auto floors = building::renderBuildingFloors(graph, solution, options.map);
  summary.floors = floors.size();
  summary.constraints = graph.constraints().size();
  for (const auto& [id, floor] : floors) {
    const std::string stem = "floor_" + std::to_string(id);
    grid::writeMapServerFiles(floor.grid, (fs::path(dir) / stem).string());
    add(stem + ".pgm");
    add(stem + ".yaml");
    grid::writePng((fs::path(dir) / (stem + ".png")).string(), grid::renderGrey(floor.grid));
    add(stem + ".png");
  }
  building::writeBuildingYaml((fs::path(dir) / "building.yaml").string(), solution, floors);
  add("building.yaml");
  if (!graph.empty()) {
    graph::writeG2o(withRankedGraphIds(graph.poseGraphAt(solution)), (fs::path(dir) / "graph.g2o").string());
    add("graph.g2o");
  }
  eval::writeTrajectoryCsv((fs::path(dir) / "trajectory.csv").string(), trajectoryRows(graph, solution));
  add("trajectory.csv");
  summary.occupied_voxels =
      building::writeBuildingOctomap((fs::path(dir) / "building.bt").string(), floors, options.octomap);
  add("building.bt");
  grid::writePng((fs::path(dir) / "overlay.png").string(), building::renderFloorOverlay(floors));
  add("overlay.png");
  const building::BuildingSolution before = extras.unaligned ? *extras.unaligned : solveWithoutConstraints(graph);
  grid::writePng((fs::path(dir) / "graph_before.png").string(), renderGraph(graph, before, false));
  grid::writePng((fs::path(dir) / "graph_after.png").string(), renderGraph(graph, solution, true));
  add("graph_before.png");
  add("graph_after.png");
  grid::writePng(
      (fs::path(dir) / "building_before.png").string(),
      building::renderIsometric(building::renderBuildingFloors(graph, before, options.map), 900,
                                &graph, &before, /*constraints=*/false));
  grid::writePng((fs::path(dir) / "building_after.png").string(),
                 building::renderIsometric(floors, 900, &graph, &solution));
  add("building_before.png");
  add("building_after.png");

  // Constraints per pair of floors.
  std::map<std::pair<int, int>, int> per_pair;
  for (const auto& c : graph.constraints()) {
    const int a = graph.floorGraphs().at(c.graph_from).floor_id, b = graph.floorGraphs().at(c.graph_to).floor_id;
    ++per_pair[{std::min(a, b), std::max(a, b)}];
  }

  std::ofstream out(fs::path(dir) / "report.html");
  if (!out)
    throw std::runtime_error((fs::path(dir) / "report.html").string() +
                             ": cannot open for writing");
  out << "<!DOCTYPE html>\n<html><head><meta charset=\"utf-8\"><title>" << htmlText(extras.title)
      << "</title>\n<style>body{font-family:sans-serif;max-width:1100px;margin:auto}"
         "table{border-collapse:collapse}td,th{border:1px solid #aaa;padding:3px "
         "8px;text-align:right}"
         "img{max-width:100%;border:1px solid #ccc}figure{display:inline-block;margin:6px}"
         "li.warn{color:#a40}</style></head><body>\n";
  out << "<h1>" << htmlText(extras.title) << "</h1>\n";
  if (!extras.input.empty()) out << "<p>Input: <code>" << htmlText(extras.input) << "</code></p>\n";
  writeSummary(out, graph, solution, extras);
  out << "<figure><img src=\"building_before.png\" width=\"440\"><figcaption>the floors at their "
         "heights without inter-floor constraints</figcaption></figure>\n"
      << "<figure><img src=\"building_after.png\" width=\"440\"><figcaption>with them "
         "(constraints black, paths and rides grey)</figcaption></figure>\n";
  writeInteractiveView(out, building::buildingScene(floors, &graph, &solution));
  out << "<h2>Floors</h2>\n<table><tr><th>floor graph</th><th>robot</th><th>floor</th><th>height [m]</th>"
         "<th>x [m]</th><th>y [m]</th><th>&theta; [deg]</th><th>aligned</th><th>nodes</th></tr>\n";
  for (const auto& p : solution.placements)
    out << "<tr><td>" << p.graph_id << "</td><td>" << htmlText(p.robot) << "</td><td>" << p.floor_id
        << "</td><td>" << fixedText(p.height, 2) << "</td><td>" << fixedText(p.transform.x(), 3)
        << "</td><td>" << fixedText(p.transform.y(), 3) << "</td><td>"
        << fixedText(p.transform.theta() * 180 / M_PI, 2) << "</td><td>"
        << (p.aligned ? "yes" : "no") << "</td><td>"
        << graph.floorGraphs().at(p.graph_id).nodes.size() << "</td></tr>\n";
  out << "</table>\n<h2>Inter-floor constraints</h2>\n<table><tr><th>floors</th><th>constraints</th></tr>\n";
  for (const auto& [pair, count] : per_pair)
    out << "<tr><td>" << pair.first << " &ndash; " << pair.second << "</td><td>" << count << "</td></tr>\n";
  if (per_pair.empty()) out << "<tr><td colspan=2>none</td></tr>\n";
  out << "</table>\n<p>&chi;&sup2; " << fixedText(solution.initial_chi2, 1) << " &rarr; "
      << fixedText(solution.final_chi2, 1) << " in " << solution.iterations << " iterations.</p>\n";
  auto evaluation_table = [&](const eval::Evaluation& e, const std::string& caption) {
    out << "<h3>" << htmlText(caption)
        << "</h3>\n<table><tr><th>floor</th><th>poses</th><th>alignment error [m]</th>"
           "<th>alignment error [deg]</th><th>ATE rmse [m]</th></tr>\n";
    for (const auto& f : e.floors)
      out << "<tr><td>" << htmlText(f.floor) << "</td><td>" << f.poses << "</td><td>"
          << fixedText(f.residual_translation, 3) << "</td><td>"
          << fixedText(f.residual_rotation * 180 / M_PI, 2) << "</td><td>"
          << fixedText(f.ate_rmse, 3) << "</td></tr>\n";
    out << "</table>\n";
    if (!e.corridors.empty()) {
      out << "<table><tr><th>corridor</th><th>true [m]</th><th>estimated [m]</th><th>error [%]</th></tr>\n";
      for (const auto& c : e.corridors)
        if (c.measured)
          out << "<tr><td>" << htmlText(c.name) << "</td><td>" << fixedText(c.true_length, 2)
              << "</td><td>" << fixedText(c.estimated_length, 2) << "</td><td>"
              << fixedText((c.ratio - 1.0) * 100, 2) << "</td></tr>\n";
      out << "</table>\n";
    }
  };
  if (extras.evaluation || extras.evaluation_unaligned) out << "<h2>Accuracy against ground truth</h2>\n";
  if (extras.evaluation_unaligned)
    evaluation_table(*extras.evaluation_unaligned, "Without inter-floor constraints");
  if (extras.evaluation) evaluation_table(*extras.evaluation, "With inter-floor constraints");
  writeTimeline(out, graph, extras.rides ? &*extras.rides : nullptr);
  if (!extras.timings.empty()) {
    out << "<h2>Timings</h2>\n<table><tr><th>phase</th><th>seconds</th></tr>\n";
    std::vector<Timing> timings = extras.timings;
    timings.push_back(
        {"outputs (maps, graph, OctoMap, pictures, this report)",
         std::chrono::duration<double>(std::chrono::steady_clock::now() - outputs_start).count()});
    double total = 0;
    for (const auto& t : timings) {
      out << "<tr><td style=\"text-align:left\">" << htmlText(t.phase) << "</td><td>"
          << fixedText(t.seconds, 2) << "</td></tr>\n";
      total += t.seconds;
    }
    out << "</table>\n";
    if (extras.recording_seconds > 0 && total > 0)
      out << "<p>Real-time factor: " << fixedText(extras.recording_seconds / total, 1) << " ("
          << fixedText(extras.recording_seconds, 1) << " s of recording in " << fixedText(total, 2)
          << " s)</p>\n";
  }
  for (const auto& note : extras.notes) out << "<p>" << htmlText(note) << "</p>\n";
  out << "<h2>Pictures</h2>\n";
  for (const auto& [id, floor] : floors)
    out << "<figure><img src=\"floor_" << id << ".png\"><figcaption>floor " << id << " (height "
        << fixedText(floor.height, 2) << " m)</figcaption></figure>\n";
  out << "<figure><img src=\"overlay.png\"><figcaption>all floors overlaid (cf. the paper's Fig. 4)</figcaption></figure>\n"
      << "<figure><img src=\"graph_before.png\"><figcaption>graph without inter-floor constraints</figcaption></figure>\n"
      << "<figure><img src=\"graph_after.png\"><figcaption>graph with inter-floor constraints (black)</figcaption></figure>\n";
  out << "</body></html>\n";
  if (!out) throw std::runtime_error((fs::path(dir) / "report.html").string() + ": write failed");
  add("report.html");
  return summary;
}

}  // namespace storey::tools
