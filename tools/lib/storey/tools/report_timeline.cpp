#include "storey/tools/report_timeline.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "storey/tools/building_report.h"

namespace storey::tools {

namespace {

struct Stretch {  // consecutive nodes of one floor graph
  double start = 0.0, end = 0.0, height = 0.0;
  int floor_id = 0;
};

std::vector<Stretch> stretchesOf(const building::BuildingGraph& graph, const std::string& robot) {
  struct Stamped {
    double t;
    int graph;
  };
  std::vector<Stamped> nodes;
  for (const auto& [id, g] : graph.floorGraphs())
    if (g.robot == robot)
      for (const auto& n : g.nodes) nodes.push_back({n.stamp, id});
  std::sort(nodes.begin(), nodes.end(),
            [](const Stamped& a, const Stamped& b) { return a.t < b.t; });
  std::vector<Stretch> out;
  for (std::size_t i = 0; i < nodes.size(); ++i) {
    const floor::FloorGraph& g = graph.floorGraphs().at(nodes[i].graph);
    if (i == 0 || nodes[i].graph != nodes[i - 1].graph)
      out.push_back({nodes[i].t, nodes[i].t, g.floor_height, g.floor_id});
    out.back().end = nodes[i].t;
  }
  return out;
}

const char* modeColour(floor::TransitMode mode) {
  switch (mode) {
    case floor::TransitMode::kElevator:
      return "#1f6fd0";
    case floor::TransitMode::kStairs:
      return "#d07a1f";
    case floor::TransitMode::kUnknown:
      break;
  }
  return "#888";
}

}  // namespace

void writeTimeline(std::ostream& out, const building::BuildingGraph& graph,
                   const RobotRides* rides) {
  std::vector<std::string> robots;
  for (const auto& [id, g] : graph.floorGraphs())
    if (std::find(robots.begin(), robots.end(), g.robot) == robots.end()) robots.push_back(g.robot);
  if (robots.empty()) return;
  out << "<h2>Timeline</h2>\n";
  for (const std::string& robot : robots) {
    const std::vector<Stretch> stretches = stretchesOf(graph, robot);
    const std::vector<floor::FloorEvent> none;
    const auto found = rides ? rides->find(robot) : RobotRides::const_iterator();
    const std::vector<floor::FloorEvent>& events =
        rides && found != rides->end() ? found->second : none;
    double t0 = std::numeric_limits<double>::infinity(), t1 = -t0, z0 = t0, z1 = -t0;
    for (const Stretch& s : stretches) {
      t0 = std::min(t0, s.start), t1 = std::max(t1, s.end);
      z0 = std::min(z0, s.height), z1 = std::max(z1, s.height);
    }
    for (const auto& e : events) {
      t0 = std::min(t0, e.start_stamp), t1 = std::max(t1, e.stamp);
      z0 = std::min({z0, e.from_height, e.floor_height}),
      z1 = std::max({z1, e.from_height, e.floor_height});
    }
    if (!(t1 > t0)) continue;
    if (!(z1 > z0)) z0 -= 1.0, z1 += 1.0;
    const int width = 880, height = 220, left = 60, right = 10, top = 10, bottom = 30;
    auto x = [&](double t) { return left + (t - t0) / (t1 - t0) * (width - left - right); };
    auto y = [&](double z) { return top + (z1 - z) / (z1 - z0) * (height - top - bottom); };
    out << "<h3>" << htmlText(robot) << "</h3>\n<svg xmlns=\"http://www.w3.org/2000/svg\" width=\""
        << width << "\" height=\"" << height << "\" style=\"border:1px solid #ccc\">\n";
    // Axes: height of each floor the robot was on, time at both ends.
    std::vector<std::pair<double, int>> levels;
    levels.reserve(stretches.size());
    for (const Stretch& s : stretches) levels.emplace_back(s.height, s.floor_id);
    std::sort(levels.begin(), levels.end());
    levels.erase(std::unique(levels.begin(), levels.end()), levels.end());
    for (const auto& [z, id] : levels)
      out << "<line x1=\"" << left << "\" x2=\"" << width - right << "\" y1=\""
          << fixedText(y(z), 1) << "\" y2=\"" << fixedText(y(z), 1)
          << "\" stroke=\"#eee\"/><text x=\"4\" y=\"" << fixedText(y(z) + 4, 1)
          << "\" font-size=\"11\">F" << id << " " << fixedText(z, 1) << " m</text>\n";
    out << "<text x=\"" << left << "\" y=\"" << height - 8 << "\" font-size=\"11\">"
        << fixedText(t0, 0) << " s</text><text x=\"" << width - right - 60 << "\" y=\""
        << height - 8 << "\" font-size=\"11\">" << fixedText(t1, 0) << " s</text>\n";
    for (const Stretch& s : stretches)
      out << "<line x1=\"" << fixedText(x(s.start), 1) << "\" x2=\""
          << fixedText(std::max(x(s.end), x(s.start) + 1), 1) << "\" y1=\""
          << fixedText(y(s.height), 1) << "\" y2=\"" << fixedText(y(s.height), 1)
          << "\" stroke=\"#333\" stroke-width=\"3\"/>\n";
    for (const auto& e : events)
      out << "<line x1=\"" << fixedText(x(e.start_stamp), 1) << "\" x2=\""
          << fixedText(x(e.stamp), 1) << "\" y1=\"" << fixedText(y(e.from_height), 1) << "\" y2=\""
          << fixedText(y(e.floor_height), 1) << "\" stroke=\"" << modeColour(e.mode)
          << "\" stroke-width=\"3\"/>\n";
    out << "</svg>\n";
    if (!rides) {
      out << "<p>The rides are not known here (a journal holds no floor events).</p>\n";
      continue;
    }
    out << "<table><tr><th>start [s]</th><th>end [s]</th><th>from</th><th>to</th><th>height change "
           "[m]</th>"
           "<th>mode</th><th>confidence</th></tr>\n";
    // The floor a ride left: the one the robot was mapping when it started.
    auto floorBefore = [&](double t) {
      int id = stretches.empty() ? 0 : stretches.front().floor_id;
      for (const Stretch& s : stretches)
        if (s.start <= t) id = s.floor_id;
      return id;
    };
    for (const auto& e : events)
      out << "<tr><td>" << fixedText(e.start_stamp, 1) << "</td><td>" << fixedText(e.stamp, 1)
          << "</td><td>F" << floorBefore(e.start_stamp) << "</td><td>F" << e.floor_id
          << (e.new_floor ? " (new)" : "") << "</td><td>" << fixedText(e.height_change, 2)
          << "</td><td>" << floor::transitModeName(e.mode) << "</td><td>"
          << fixedText(e.confidence, 2) << "</td></tr>\n";
    if (events.empty()) out << "<tr><td colspan=7>no ride reported</td></tr>\n";
    out << "</table>\n";
  }
  out << "<p>Black: the floors the robot mapped, over time; coloured: the rides its floor detector "
         "reported (blue elevator, orange stairs, grey unknown).</p>\n";
}

}  // namespace storey::tools
