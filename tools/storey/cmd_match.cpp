// storey match: inter-floor constraints between floor graphs by global Monte Carlo
// localisation, printing every candidate's provenance and, where the truth is known
// (simulated buildings, logs moved by a known offset), each accepted constraint's error.
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <iomanip>
#include <iostream>
#include <limits>
#include <map>
#include <set>
#include <sstream>

#include "args.h"
#include "storey/building/journal.h"
#include "storey/common/config.h"
#include "storey/common/log.h"
#include "storey/eval/log_floors.h"
#include "storey/eval/metrics.h"
#include "storey/eval/simulated_floors.h"
#include "storey/eval/trajectory.h"
#include "storey/floor_matcher/floor_matcher_component.h"
#include "storey/io/carmen.h"
#include "storey/matching/floor_matcher.h"
#include "storey/matching/growth_passes.h"
#include "storey/matching/retraction.h"
#include "storey/sim/scenario.h"
#include "storey/sim/simulator.h"

namespace storey::cli {

extern const char* const summary_match =
    "find inter-floor constraints (MCL + likelihood gate + RANSAC) and print their provenance";

namespace {

using geometry::Pose2;

std::vector<double> numbers(const std::string& text, std::size_t count, const std::string& option) {
  std::vector<double> values;
  std::stringstream in(text);
  for (std::string item; std::getline(in, item, ',');) {
    try {
      std::size_t used = 0;
      values.push_back(std::stod(item, &used));
      if (used != item.size()) throw std::invalid_argument(item);
    } catch (const std::exception&) {
      throw UsageError("--" + option + ": '" + item + "' is not a number");
    }
  }
  if (values.size() != count)
    throw UsageError("--" + option + " takes " + std::to_string(count) +
                     " comma-separated numbers");
  return values;
}

bool endsWith(const std::string& s, const std::string& suffix) {
  return s.size() >= suffix.size() &&
         s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

void printErrors(const matching::MatchResult& result, const eval::SimulatedFloors& floors) {
  std::cout << "errors against the truth:\n";
  int wrong = 0, off = 0;
  for (const auto& c : result.constraints) {
    const auto e = eval::judgeConstraint(c, floors);
    wrong += e.wrong;
    off += e.off;
    std::cout << "  graph " << c.graph_id << " node " << c.node_id << " -> graph "
              << c.reference_graph_id << " node " << c.reference_node_id << ": " << std::fixed
              << std::setprecision(3) << e.translation << " m (" << e.along_weak
              << " along its weak direction, claimed sigma " << e.weak_sigma << "), "
              << e.rotation * 180.0 / M_PI << " deg"
              << (e.wrong ? "  WRONG" : e.off ? "  off along its weak direction" : "") << "\n";
  }
  for (const auto& p : result.pairs) {
    if (!p.accepted) continue;
    const auto e = eval::alignmentError(p.alignment, p.reference_graph_id, p.graph_id, floors);
    std::cout << "  alignment of graph " << p.graph_id << " in graph " << p.reference_graph_id
              << ": " << std::fixed << std::setprecision(3) << e.translation << " m, "
              << e.rotation * 180.0 / M_PI << " deg"
              << (floors.node_truth.empty() ? "" : " (against the graphs' rigid fits to the truth)") << "\n";
  }
  const matching::WrongConstraintLimits limits;  // the ones judgeConstraint used
  std::cout << std::defaultfloat << wrong << " wrong constraints (more than " << limits.rotation * 180.0 / M_PI << " deg, or "
            << limits.translation << " m across their weak direction, or max(" << limits.translation << " m, "
            << limits.weak_sigmas << " claimed sigmas) along it); " << off << " more than "
            << limits.translation << " m or " << limits.rotation * 180.0 / M_PI << " deg off in some direction\n";
}

// Every candidate that passed the gate, against the truth, with where its scans were (the
// true positions of its first and last scans, building frame): shows which sequences
// found the shared structure and which converged elsewhere.
void printCandidateTruth(const matching::MatchResult& result, const eval::SimulatedFloors& floors,
                         const matching::FloorMatcherOptions& options) {
  std::map<std::size_t, matching::PreparedFloor> prepared;  // maps, for the false ones
  auto indexOf = [&](int id) {
    for (std::size_t i = 0; i < floors.graphs.size(); ++i)
      if (floors.graphs[i].graph_id == id) return i;
    return floors.graphs.size();
  };
  std::cout << "gated candidates against the truth (building-frame positions of scans k..m):\n";
  for (const auto& p : result.pairs) {
    for (const auto& c : p.candidates) {
      // A pair combined through an aligned graph holds candidates of two pairs: each
      // names its own.
      const std::size_t ri = indexOf(c.reference_graph_id), gi = indexOf(c.graph_id);
      if (ri >= floors.graphs.size() || gi >= floors.graphs.size() || ri == gi) continue;
      if (c.status == matching::CandidateStatus::kLowLikelihood ||
          c.status == matching::CandidateStatus::kPoorFit)
        continue;  // (underconstrained ones are shown: what the conditioning gate drops)
      eval::ConstraintError e;
      const std::size_t si = c.reversed ? ri : gi;  // the graph whose scans were localised
      const std::size_t mi = c.reversed ? gi : ri;  // the graph whose map they were localised in
      const auto& nodes = floors.graphs[si].nodes;
      const Pose2 a = eval::trueNodePose(floors, si, nodes[c.first_index]);
      const Pose2 b = eval::trueNodePose(floors, si, nodes[c.last_index]);
      // Where the candidate puts the sequence's last scan (building frame, via the
      // reference's true frame): for a false one, the place that looked alike.
      Pose2 placed = c.reversed ? floors.frames[gi] * c.alignment.inverse() * nodes[c.last_index].pose
                                : floors.frames[ri] * c.alignment * nodes[c.last_index].pose;
      // The alignment that would have put the last scan at its true place.
      Pose2 truth = floors.frames[mi].inverse() * floors.frames[si];
      if (!floors.node_truth.empty()) {
        // Mapped graphs bend: judge the candidate where its last scan lies, through the
        // true pose of the map's node nearest to where it placed that scan.
        const Pose2 in_map = (c.reversed ? c.alignment.inverse() : c.alignment) * nodes[c.last_index].pose;
        const floor::FloorGraph& mg = floors.graphs[mi];
        const floor::FloorNode& q = mg.nodes[mg.nearestNodeIndex(in_map.translation())];
        const Pose2 q_true = eval::trueNodePose(floors, mi, q);
        placed = q_true * q.pose.between(in_map);
        e.translation = (placed.translation() - b.translation()).norm();
        e.rotation = std::abs(geometry::angleDiff(placed.theta(), b.theta()));
        truth = q.pose * q_true.between(b) * nodes[c.last_index].pose.inverse();
      } else {
        e = eval::alignmentError(c.alignment, c.reference_graph_id, c.graph_id, floors);
      }
      const bool bad = e.translation > 0.3 || e.rotation > 2.0 * M_PI / 180.0;
      std::cout << "  graph " << c.graph_id << " in " << c.reference_graph_id << " "
                << (c.reversed ? "ref scans " : "scans ") << (c.backwards ? "<" : "")
                << c.first_index << ".." << c.last_index << std::fixed << std::setprecision(1)
                << " (" << a.x() << "," << a.y() << ")->(" << b.x() << "," << b.y() << ") "
                << matching::candidateStatusName(c.status) << std::setprecision(3) << "  l_t "
                << c.likelihood << "  through " << c.see_through << "  ratio " << c.information_ratio << "  "
                << e.translation << " m "
                << e.rotation * 180.0 / M_PI << " deg";
      if (bad) {
        // The same scans at the true alignment: the fit and the see-through fraction the
        // true place would have had, against those of the place the filter chose.
        auto it = prepared.find(mi);
        if (it == prepared.end())
          it = prepared.emplace(mi, matching::prepareFloor(floors.graphs[mi], options)).first;
        const matching::PreparedFloor& map = it->second;
        Pose2 chosen = c.reversed ? c.alignment.inverse() : c.alignment;
        const std::vector<std::pair<int, int>> range{{c.first_index, c.last_index}};
        const double through_truth =
            matching::seeThroughFraction(map.map->frame(), map.walls(options), floors.graphs[si],
                                         range, options.refine_beams, truth, 0.3);
        const double fit_truth = matching::refineAlignment(map.map->field(), floors.graphs[si],
                                                           range, options.refine_beams, 0, &truth);
        const double fit_chosen = matching::refineAlignment(
            map.map->field(), floors.graphs[si], range, options.refine_beams, 0, &chosen);
        std::cout << std::setprecision(3) << "  [truth: fit " << fit_truth << " vs " << fit_chosen
                  << ", through " << through_truth << "]";
      }
      if (bad)
        std::cout << std::setprecision(1) << "  FALSE: scan " << c.last_index << " at (" << b.x()
                  << "," << b.y() << "," << b.theta() * 180.0 / M_PI << " deg) placed at ("
                  << placed.x() << "," << placed.y() << "," << placed.theta() * 180.0 / M_PI
                  << " deg)";
      std::cout << "\n";
      std::cout.unsetf(std::ios::fixed);
    }
  }
}

// The floor graphs a mapped building ended with, from its graph server journal.
std::vector<floor::FloorGraph> journalFloorGraphs(const std::string& path) {
  const building::JournalBuilding journal = building::rebuildFromJournal(path);
  building::printJournalProblems(std::cerr, path, journal);
  std::vector<floor::FloorGraph> graphs;
  for (const auto& [id, g] : journal.graph.floorGraphs()) graphs.push_back(g);
  if (graphs.empty()) throw std::runtime_error(path + ": the journal holds no floor graph");
  return graphs;
}

// Each node's true pose (the ground truth at its stamp), and each graph's frame: its node
// positions fitted to those (one rigid fit per graph). A mapped floor is not exactly
// rigid: constraints and candidates are judged by the true poses of their own nodes; the
// fitted frame only places a floor as a whole.
void fitTruth(const std::vector<eval::PoseRow>& truth, const std::string& truth_path,
              eval::SimulatedFloors* floors) {
  const std::vector<floor::FloorGraph>& graphs = floors->graphs;
  floors->frames.clear();
  floors->node_truth.assign(graphs.size(), {});
  for (std::size_t gi = 0; gi < graphs.size(); ++gi) {
    const floor::FloorGraph& g = graphs[gi];
    std::vector<eval::PoseRow> nodes;
    for (const auto& n : g.nodes) {
      eval::PoseRow row;
      row.stamp = n.stamp;
      row.robot = g.robot;
      row.pose = n.pose;
      nodes.push_back(row);
    }
    std::vector<eval::PoseRow> mine;  // this robot's truth while its nodes were taken
    for (const auto& row : truth)
      if (row.robot == g.robot && !g.nodes.empty() && row.stamp >= g.nodes.front().stamp &&
          row.stamp <= g.nodes.back().stamp)
        mine.push_back(row);
    const auto pairs = eval::associate(nodes, mine, 0.05, 0.5);
    std::vector<Eigen::Vector2d> from, to;
    for (const auto& p : pairs) {
      from.push_back(p.estimate.translation());
      to.push_back(p.truth.translation());
    }
    // The other way round, the truth interpolated at each node's stamp.
    std::map<double, int> node_at;  // stamp -> node id
    for (const auto& n : g.nodes) node_at[n.stamp] = n.id;
    for (const auto& p : eval::associate(mine, nodes, 0.05, 0.5)) {
      const auto it = node_at.find(p.stamp);
      if (it != node_at.end()) floors->node_truth[gi][it->second] = p.estimate;
    }
    if (from.size() < 2)
      throw std::runtime_error(truth_path + ": no ground truth for graph " + std::to_string(g.graph_id) +
                               " (robot " + g.robot + ")");
    floors->frames.push_back(eval::alignPoints(from, to));
  }
}

// Matching while the graphs grow, as a live matcher does: a pass on the graphs as they
// stood at each of `times` (the last: the whole graphs), each retracting what the passes
// before published and it no longer stands behind. With the truth, each published and
// retracted constraint is judged; "wrong standing" counts wrong constraints a graph server
// would hold after the pass.
void matchInStages(const eval::SimulatedFloors& floors,
                   const matching::FloorMatcherOptions& options,
                   const matching::RetractionOptions& retraction, const std::vector<double>& times,
                   std::size_t min_nodes, bool confirm) {
  const double first = matching::nodeStampSpan(floors.graphs).first;
  const bool judged = floors.frames.size() == floors.graphs.size();
  auto wrong = [&](const matching::InterFloorConstraint& c) {
    return judged && eval::judgeConstraint(c, floors).wrong;
  };
  std::vector<matching::InterFloorConstraint> published;
  matching::PlacementHistory history;  // the passes' placements (confirm)
  int total_wrong_published = 0, total_retracted = 0, total_wrong_retracted = 0, worst_wrong_standing = 0;
  for (std::size_t k = 0; k < times.size(); ++k) {
    const double until = times[k];
    const bool final_pass = k + 1 == times.size();
    const auto graphs = matching::graphsUntil(floors.graphs, until, min_nodes);
    std::cout << "stage " << k + 1 << " (t " << std::fixed << std::setprecision(1) << until - first << " s):";
    std::cout.unsetf(std::ios::fixed);
    for (const auto& g : graphs) std::cout << " [" << g.graph_id << "] " << g.nodes.size();
    if (graphs.size() < 2) {
      std::cout << "  fewer than two graphs of " << min_nodes << " nodes: not matched\n";
      continue;
    }
    const matching::MatchResult result = matching::matchFloors(graphs, options);
    const matching::GrowthPassConfirmation confirmation(graphs, result, history, retraction,
                                                        options.floor_change);
    const auto retract = matching::constraintsToRetract(
        published, graphs, result, retraction, confirm && !final_pass ? &confirmation : nullptr);
    int retracted_wrong = 0;
    std::vector<bool> drop(published.size(), false);
    for (const auto& r : retract) {
      drop[r.index] = true;
      retracted_wrong += wrong(published[r.index]);
    }
    std::vector<matching::InterFloorConstraint> standing;
    for (std::size_t i = 0; i < published.size(); ++i)
      if (!drop[i]) standing.push_back(published[i]);
    int added = 0, added_wrong = 0, unconfirmed = 0;
    std::vector<std::string> wrong_notes;
    for (const auto& c : result.constraints) {
      // Until the last pass (a flush: the graphs are final), only what the component's
      // growth passes publish.
      if (confirm && !final_pass && !confirmation.confirms(c)) {
        ++unconfirmed;
        continue;
      }
      const bool held = std::any_of(standing.begin(), standing.end(), [&](const auto& s) {
        return s.reference_graph_id == c.reference_graph_id && s.reference_node_id == c.reference_node_id &&
               s.graph_id == c.graph_id && s.node_id == c.node_id;
      });
      if (held) continue;
      standing.push_back(c);
      ++added;
      if (wrong(c)) {
        ++added_wrong;
        const matching::ConstraintJudgement j = eval::judgeConstraint(c, floors);
        std::ostringstream note;
        note << std::fixed << std::setprecision(3) << "published wrong: graph " << c.graph_id << " node "
             << c.node_id << " -> graph " << c.reference_graph_id << " node " << c.reference_node_id << ": "
             << j.translation << " m (" << j.along_weak << " along its weak direction, claimed sigma "
             << j.weak_sigma << "), " << std::setprecision(2) << j.rotation * 180.0 / M_PI << " deg";
        wrong_notes.push_back(note.str());
      }
    }
    published = std::move(standing);
    history.record(graphs, result);
    int wrong_standing = 0;
    for (const auto& c : published) wrong_standing += wrong(c);
    total_wrong_published += added_wrong;
    total_retracted += static_cast<int>(retract.size());
    total_wrong_retracted += retracted_wrong;
    worst_wrong_standing = std::max(worst_wrong_standing, wrong_standing);
    std::cout << "  accepted " << result.constraints.size() << ", new " << added << ", retracted "
              << retract.size() << ", standing " << published.size();
    if (confirm) std::cout << ", unconfirmed " << unconfirmed;
    if (judged)
      std::cout << "  (wrong: new " << added_wrong << ", retracted " << retracted_wrong << ", standing "
                << wrong_standing << ")";
    std::cout << "\n";
    for (const auto& r : retract) std::cout << "    retracted: " << r.reason << "\n";
    for (const auto& note : wrong_notes) std::cout << "    " << note << "\n";
    if (confirm && !final_pass)
      for (const auto& [graph, why] : confirmation.atOddsWithTransits())
        std::cout << "    held back for graph " << graph << ": " << why << "\n";
  }
  std::cout << "stages: " << times.size() << " passes, " << total_retracted << " retracted";
  if (judged)
    std::cout << " (" << total_wrong_retracted << " wrong); " << total_wrong_published
              << " wrong published over all stages, at most " << worst_wrong_standing << " wrong standing after a pass";
  std::cout << "\n";
}

}  // namespace

int run_match(Args& args) {
  args.usage("INPUT...",
             "Matches floor graphs with the floor matcher and prints every candidate: which\n"
             "scans, which nodes, l_t against l_min, refinement fit, RANSAC verdict and why.\n"
             "INPUT is a simulator scenario (building .yaml: simulated with --sim-seed, one\n"
             "floor graph per robot and floor, true poses in a random frame per graph), a\n"
             "graph server journal (journal.bin of storey map: the floor graphs the mapper\n"
             "made, judged against --truth or the recording/ground_truth beside it), or one\n"
             "or two CARMEN corrected logs: two logs are two floors; one log is split into\n"
             "halves. The second floor is moved by --offset and --dz and gets fresh odometry\n"
             "noise, so the recovered alignment can be checked against the known offset.")
      .option("config", "FILE", "floor matcher options (YAML with a floor_matcher: key)")
      .option("seed", "N", "matcher seed", "1")
      .option("sim-seed", "N", "simulator seed (scenario input)", "1")
      .option("offset", "X,Y,DEG", "frame of the second log floor in the first's", "3.0,-2.0,25.0")
      .option("dz", "METRES", "height of the second log floor", "3.0")
      .option("threads", "N", "worker threads (overrides the config)", "")
      .option("truth", "CSV", "ground-truth trajectory.csv for a journal input", "")
      .option("at", "SECONDS", "journal input: match the graphs as they stood this long after the first node", "")
      .option("stages", "N",
              "match N times on the graphs as they grew (nodes up to evenly spaced times), retracting "
              "what a pass no longer stands behind, as a live matcher does (0: once, on the whole graphs)",
              "0")
      .flag("growth-passes",
            "match whenever a graph has grown as the floor_matcher component's trigger "
            "(min_nodes, min_new_nodes, min_growth of --config) starts a pass, then on the whole graphs")
      .flag("confirm", "--stages, --growth-passes: a pass before the last publishes only what an earlier pass placed the same way on retraction.confirm_growth less of one of the pair's graphs")
      .flag("quiet", "print only the summary and errors");
  if (!args.parse()) return 0;
  const std::vector<std::string>& inputs = args.positionals();
  if (inputs.empty() || inputs.size() > 2)
    throw UsageError("give a scenario .yaml or one or two logs");

  // The component's parameter file: the matcher's options, retraction, and the growth
  // trigger (--growth-passes).
  floor_matcher::FloorMatcherComponentOptions component;
  if (args.has("config"))
    component = floor_matcher::readFloorMatcherComponentOptions(common::ConfigNode::loadFile(args.get("config")));
  matching::FloorMatcherOptions options = component.matcher;
  const matching::RetractionOptions retraction = component.retraction;
  const int stages = static_cast<int>(args.getInt("stages"));
  if (stages < 0) throw UsageError("--stages: give 0 or more");
  options.seed = static_cast<std::uint64_t>(args.getInt("seed"));
  if (args.has("threads") && !args.get("threads").empty())
    options.threads = static_cast<int>(args.getInt("threads"));

  eval::SimulatedFloors floors;
  if (inputs.size() == 1 && endsWith(inputs[0], ".yaml")) {
    const sim::Scenario scenario = sim::loadScenario(inputs[0]);
    const sim::Simulation run =
        sim::simulate(scenario, static_cast<std::uint64_t>(args.getInt("sim-seed")));
    eval::SimulatedFloorsOptions so;
    so.seed = static_cast<std::uint64_t>(args.getInt("sim-seed"));
    floors = eval::floorGraphsFromSimulation(run, so);
  } else if (inputs.size() == 1 && endsWith(inputs[0], ".bin")) {
    floors.graphs = journalFloorGraphs(inputs[0]);
    if (args.has("at") && !args.get("at").empty()) {
      const double first = matching::nodeStampSpan(floors.graphs).first;
      floors.graphs = matching::graphsUntil(floors.graphs, first + args.getDouble("at"), 10);
    }
    std::string truth_path = args.get("truth");
    if (truth_path.empty()) {
      const auto beside = std::filesystem::path(inputs[0]).parent_path() / "recording" / "ground_truth" /
                          "trajectory.csv";
      if (std::filesystem::exists(beside)) truth_path = beside.string();
    }
    if (truth_path.empty()) {
      std::cout << "no ground truth (--truth): candidates and constraints are not judged\n";
    } else {
      fitTruth(eval::readTrajectoryCsv(truth_path), truth_path, &floors);
      std::cout << "truth: " << truth_path << "\n";
    }
  } else {
    const auto offset = numbers(args.get("offset"), 3, "offset");
    const Pose2 frame(offset[0], offset[1], offset[2] * M_PI / 180.0);
    std::vector<std::vector<io::CarmenLaser>> logs;
    for (const auto& path : inputs) logs.push_back(io::readCarmenLasers(path));
    eval::LogFloorOptions a, b;
    a.seed = options.seed * 2 + 1;
    b.seed = options.seed * 2 + 2;
    b.graph_id = b.floor_id = 1;
    b.floor_height = args.getDouble("dz");
    b.frame = frame;
    const auto& second = logs.size() == 2 ? logs[1] : logs[0];
    if (logs.size() == 1) {
      a.last = logs[0].size() / 2;
      b.first = logs[0].size() / 2;
    }
    floors.graphs.push_back(eval::floorGraphFromLasers(logs[0], a));
    floors.graphs.push_back(eval::floorGraphFromLasers(second, b));
    floors.frames = {Pose2(), frame};
  }
  std::cout << floors.graphs.size() << " floor graphs:";
  for (const auto& g : floors.graphs)
    std::cout << "  [" << g.graph_id << "] " << g.robot << " floor " << g.floor_id << " h "
              << g.floor_height << " (" << g.nodes.size() << " nodes)";
  std::cout << "\n";
  if (stages > 0 || args.flagSet("growth-passes")) {
    if (stages > 0 && args.flagSet("growth-passes")) throw UsageError("give --stages or --growth-passes, not both");
    std::vector<double> times;
    if (stages > 0) {
      const auto [first, last] = matching::nodeStampSpan(floors.graphs);
      for (int k = 1; k <= stages; ++k) times.push_back(first + (last - first) * k / stages);
    } else {
      times = matching::growthPassTimes(floors.graphs, component.trigger);
    }
    matchInStages(floors, options, retraction, times, static_cast<std::size_t>(component.trigger.min_nodes),
                  args.flagSet("confirm"));
    return 0;
  }
  const matching::MatchResult result = matching::matchFloors(floors.graphs, options);
  if (args.flagSet("quiet")) {
    for (const auto& p : result.pairs)
      std::cout << "graph " << p.graph_id << " in " << p.reference_graph_id << ": " << p.reason
                << "\n";
    std::cout << result.constraints.size() << " constraints accepted; " << result.beam_evaluations
              << " particle-beam evaluations in " << result.seconds << " s\n";
  } else {
    matching::printMatchReport(std::cout, result);
  }
  if (floors.frames.size() != floors.graphs.size()) return 0;  // no truth to judge by
  if (!args.flagSet("quiet")) printCandidateTruth(result, floors, options);
  printErrors(result, floors);
  return 0;
}

}  // namespace storey::cli
