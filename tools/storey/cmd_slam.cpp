// storey slam LOG: the per-floor front end alone on a laser log or a bag, writing the graph,
// the map and the trajectory, and (when there are reference poses) the relation error.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <map>
#include <sstream>

#include "args.h"
#include "slam_input.h"
#include "storey/bag/bag_error.h"
#include "storey/common/config.h"
#include "storey/common/log.h"
#include "storey/detection/floor_detector.h"
#include "storey/eval/trajectory.h"
#include "storey/floor/floor_graph.h"
#include "storey/graph/graph_io.h"
#include "storey/grid/image.h"
#include "storey/io/carmen.h"
#include "storey/eval/slam_evaluation.h"
#include "storey/mapping/floor_sessions.h"
#include "storey/mapping/floor_slam.h"
#include "storey/mapping/input_sequencer.h"
#include "storey/runtime/sensor_bag.h"
#include "storey/tools/map_job.h"
#include "storey/tools/robot_setup.h"

namespace storey::cli {

extern const char* const summary_slam = "run the floor SLAM front end on a laser log or a bag";

namespace {

using geometry::Pose2;

std::vector<double> parseList(const std::string& text, std::size_t count, const std::string& option) {
  std::vector<double> values;
  std::stringstream in(text);
  std::string item;
  while (std::getline(in, item, ',')) {
    try {
      std::size_t used = 0;
      values.push_back(std::stod(item, &used));
      if (used != item.size()) throw std::invalid_argument(item);
    } catch (const std::exception&) {
      throw UsageError(common::str("--", option, ": '", item, "' is not a number"));
    }
  }
  if (values.size() != count) throw UsageError("--" + option + " takes " + std::to_string(count) + " numbers");
  return values;
}

// One line: the odometry noise rates fitted to a graph's odometry edges, next to the configured
// ones.
void printOdometryFit(std::ostream& out, const char* poses, const eval::OdometryNoiseFit& fit,
                      const mapping::OdometryNoiseModel& configured) {
  if (fit.steps == 0) return;
  const auto rates = [](const mapping::OdometryNoiseModel& m) {
    std::ostringstream s;
    s << std::fixed << std::setprecision(3) << "translation_per_meter " << m.translation_per_meter
      << "  rotation_per_meter " << m.rotation_per_meter << "  rotation_per_radian "
      << m.rotation_per_radian;
    return s.str();
  };
  const mapping::OdometryNoiseModel& m = fit.model;
  const bool a_floor_explains = m.translation_per_meter == 0.0 ||
                                (m.rotation_per_meter == 0.0 && m.rotation_per_radian == 0.0);
  out << "odometry noise fitted to " << poses << " (" << fit.steps << " steps): " << rates(m)
      << (a_floor_explains ? "  (0: the minimum standard deviation alone explains the steps)" : "")
      << "\n  configured (slam.odometry_noise):                " << rates(configured) << "\n";
}

void printStats(std::ostream& out, const char* name, const eval::ErrorStats& s) {
  out << std::fixed << std::setprecision(4) << "  " << name << " pairs: " << s.count
      << "  translation " << s.translation_mean << " ± " << s.translation_std << " m"
      << "  rotation " << std::setprecision(3) << s.rotation_mean * 180.0 / M_PI << " ± "
      << s.rotation_std * 180.0 / M_PI << " deg\n";
}

// One row per loop-closure attempt; with reference poses, the measurement's error against
// them (in the candidate's frame) and its NEES under the information it claimed.
void writeLoopAttempts(const std::string& path, const std::vector<mapping::LoopClosureAttempt>& attempts,
                       const std::map<int, Pose2>* reference) {
  std::ofstream csv(path);
  csv << "node,candidate,outcome,score,chi2,dx,dy,dtheta,error_x,error_y,error_theta,nees,"
         "prediction_error_x,prediction_error_y,prediction_error_theta,linear_window,angular_window,"
         "together,sigma,relocated,followed,not_unique\n"
      << std::setprecision(6);
  for (const auto& a : attempts) {
    const bool matched = a.outcome != mapping::LoopOutcome::kNoMatch;
    csv << a.node << ',' << a.candidate << ',' << mapping::loopOutcomeName(a.outcome) << ',' << a.score << ','
        << a.chi2 << ',';
    if (matched) csv << a.measurement.x() << ',' << a.measurement.y() << ',' << a.measurement.theta();
    else csv << ",,";
    const bool known = reference && reference->count(a.node) && reference->count(a.candidate);
    const Pose2 truth = known ? reference->at(a.candidate).between(reference->at(a.node)) : Pose2();
    if (matched && known) {
      const Pose2 error = truth.between(a.measurement);
      const Eigen::Vector3d e(error.x(), error.y(), error.theta());
      csv << ',' << error.x() << ',' << error.y() << ',' << error.theta() << ',' << e.dot(a.information * e);
    } else {
      csv << ",,,,";
    }
    if (known) {
      const Pose2 error = truth.between(a.predicted);
      csv << ',' << error.x() << ',' << error.y() << ',' << error.theta();
    } else {
      csv << ",,,";
    }
    csv << ',' << a.linear_window << ',' << a.angular_window << ',' << a.together << ',' << a.sigma << ','
        << (a.relocated ? 1 : 0) << ',' << (a.followed ? 1 : 0) << ',' << (a.not_unique ? 1 : 0) << '\n';
  }
}

// graph.g2o, map.{pgm,yaml,png} of one floor graph in `dir`.
void writeGraphAndMap(const graph::PoseGraph& pose_graph, const floor::FloorGraph& floor_graph,
                      const std::string& dir) {
  std::filesystem::create_directories(dir);
  graph::writeG2o(pose_graph, dir + "/graph.g2o");
  grid::OccupancyGridOptions grid_options;
  grid_options.resolution = 0.05;
  const grid::OccupancyGrid map = floor::renderFloorMap(floor_graph, grid_options);
  grid::writeMapServerFiles(map, dir + "/map");
  grid::writePng(dir + "/map.png", grid::renderGrey(map));
}

bool changesFloor(const std::vector<detection::FloorEvent>& events) {
  return std::any_of(events.begin(), events.end(), [](const detection::FloorEvent& e) {
    return e.type == detection::FloorEventType::kTransitEnded && e.floor_changed;
  });
}

// A bag whose robot rode to other floors: its scans and rides go through the floor
// mapper's own FloorSessions, so each floor gets its graph (a floor visited again is
// resumed after global relocalisation, or, failing that, gets a new graph). A ride applies
// after every scan stamped up to when the detector decided it, as the component's
// InputSequencer orders them. Each graph is written in its own frame (aligning floors is
// the floor matcher's job: storey map) to OUTPUT/floor_<F>_graph_<G>/, its trajectory one
// row per node; with a reference, each graph's relation error over its nodes.
int mapFloors(const mapping::FloorSlamOptions& options, const SlamInput& input,
              const std::string& out_dir) {
  const std::vector<sensor::LaserScan>& scans = input.scans;
  mapping::FloorSessions sessions(options, "robot");
  std::size_t next_event = 0;
  std::size_t rides = 0;
  auto applyEvent = [&](const detection::FloorEvent& e) {
    if (e.type == detection::FloorEventType::kTransitStarted) {
      sessions.beginTransit();
    } else if (e.type == detection::FloorEventType::kTransitEnded) {
      // The detector ran alone (nothing answers an unsure arrival): its choice stands.
      sessions.endTransit(e.floor_id, e.floor_height, e.stamp);
      ++rides;
    }
  };
  const auto start = std::chrono::steady_clock::now();
  for (std::size_t i = 0; i < scans.size(); ++i) {
    while (next_event < input.floor_events.size() &&
           input.floor_events[next_event].decided_at < scans[i].stamp)
      applyEvent(input.floor_events[next_event++]);
    sessions.addScan(scans[i], input.odometry[i]);
  }
  sessions.flush();
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();

  std::vector<const mapping::FloorSlam*> graphs;
  for (const auto& slam : sessions.retired()) graphs.push_back(slam.get());
  for (const auto& [floor_id, slam] : sessions.floors()) graphs.push_back(slam.get());
  std::sort(graphs.begin(), graphs.end(),
            [](const mapping::FloorSlam* a, const mapping::FloorSlam* b) {
              return a->floorGraph().graph_id < b->floorGraph().graph_id;
            });
  // A node's scan is one of the input's, found by its stamp (one robot: stamps increase).
  std::map<double, std::size_t> scan_index;
  for (std::size_t i = 0; i < scans.size(); ++i) scan_index.emplace(scans[i].stamp, i);

  std::ostringstream report;
  report << input.source << "\n"
         << "scans: " << scans.size() << "  rides: " << rides
         << " (floor detector)  floor graphs: ";
  std::size_t written = 0;
  for (const auto* g : graphs) written += g->floorGraph().nodes.empty() ? 0 : 1;
  report << written << "  global relocalisations: " << sessions.stats().global_relocalizations
         << "  fallbacks to a new graph: " << sessions.stats().fallbacks << "\n";
  report << std::fixed << std::setprecision(2) << "processing: " << seconds
         << " s  log duration: " << input.duration
         << " s  real-time factor: " << input.duration / seconds << "\n";
  report << "odometry: " << input.odometry_note << "\n";
  std::string folders;
  for (const auto* slam : graphs) {
    const floor::FloorGraph& fg = slam->floorGraph();
    if (fg.nodes.empty()) continue;
    const std::string name = common::str("floor_", fg.floor_id, "_graph_", fg.graph_id);
    folders += (folders.empty() ? "" : ",") + name;
    writeGraphAndMap(slam->poseGraph(), fg, common::str(out_dir, "/", name));
    std::vector<Pose2> estimate, reference, odometry;
    std::map<int, Pose2> node_reference;
    {
      std::ofstream csv(common::str(out_dir, "/", name, "/trajectory.csv"));
      csv << "stamp,x,y,theta,status\n" << std::setprecision(10);
      for (const auto& node : fg.nodes) {
        csv << node.scan.stamp << ',' << node.pose.x() << ',' << node.pose.y() << ','
            << node.pose.theta() << ",node\n";
        const auto found = scan_index.find(node.scan.stamp);
        if (found == scan_index.end()) continue;
        estimate.push_back(node.pose);
        odometry.push_back(input.odometry[found->second]);
        if (!input.reference.empty()) {
          reference.push_back(input.reference[found->second]);
          node_reference[node.id] = input.reference[found->second];
        }
      }
    }
    const auto& st = slam->stats();
    report << name << ": nodes: " << fg.nodes.size() << "  matched: " << st.matched
           << "  match failures: " << st.match_failures << "  loop closures: " << st.loop_closures
           << " of " << st.loop_attempts << " attempts\n";
    printOdometryFit(report, "its finished graph", eval::fitOdometryNoise(fg, options.odometry),
                     options.odometry);
    if (!input.reference.empty())
      printOdometryFit(report, "the reference",
                       eval::fitOdometryNoise(fg, node_reference, options.odometry),
                       options.odometry);
    if (!input.reference.empty() && estimate.size() >= 2) {
      const eval::RelationErrors errors = eval::relationErrors(estimate, reference);
      const eval::RelationErrors odo = eval::relationErrors(odometry, reference);
      report
          << "relation error (Kümmerle et al. 2009) over its nodes against the reference poses:\n";
      printStats(report, "slam     nearby", errors.nearby);
      if (errors.far.count > 0) printStats(report, "slam     far   ", errors.far);
      printStats(report, "odometry nearby", odo.nearby);
      if (odo.far.count > 0) printStats(report, "odometry far   ", odo.far);
    }
  }
  std::cout << report.str();
  std::filesystem::create_directories(out_dir);
  std::ofstream(out_dir + "/report.txt") << report.str();
  std::cout << "wrote " << out_dir << "/report.txt and " << out_dir << "/{" << folders
            << "}/{graph.g2o,map.pgm,map.yaml,map.png,trajectory.csv}\n";
  return 0;
}

}  // namespace

int run_slam(Args& args) {
  args.usage("LOG",
             "Runs the per-floor SLAM front end (scan matching, loop closure, pose graph) on a\n"
             "CARMEN log, a GMapping .gfs log or a bag (rosbag2: a folder or .db3, e.g. what\n"
             "`storey record` or `storey simulate` wrote) and writes OUTPUT/graph.g2o,\n"
             "OUTPUT/map.{pgm,yaml,png} and OUTPUT/trajectory.csv. When the floor detector finds\n"
             "in a bag that the robot rode to another floor, each floor gets its own graph, as\n"
             "in the floor_mapper component, written to OUTPUT/floor_<F>_graph_<G>/ (each in\n"
             "its own frame; `storey map` aligns them).\n"
             "Logs: with --odometry simulated (the default), odometry is derived from the log's\n"
             "(corrected) poses with seeded noise and the result is compared with those poses by\n"
             "the relation metric (Kümmerle et al. 2009). With --odometry recorded, the pose on\n"
             "each laser line is the odometry; with --odometry stream, the log's ODOM lines\n"
             "interpolated at each scan's stamp (as the floor_mapper pairs them live; csail's\n"
             ".gfs has both). --reference names a log of the same scans whose poses serve as\n"
             "reference.\n"
             "Bags: one robot's scans with its recorded odometry (interpolated at each scan's\n"
             "stamp); --truth compares with a ground-truth trajectory.csv, --reference with the\n"
             "poses of the log the bag was converted from (by stamp). A `storey simulate` output\n"
             "folder may be given as LOG: its bag/, and its ground_truth/ as the truth.\n"
             "The report gives the odometry noise rates the finished graph's poses (and the\n"
             "reference's) make most likely, to calibrate slam.odometry_noise for a robot.")
      .option("output", "DIR", "output folder", "slam_out")
      .option("config", "FILE",
              "front-end options: the 'slam' section of this YAML file (e.g. "
              "config/floor_mapper.yaml) and, for a bag, its max_odometry_gap; default: "
              "the shipped config/floor_mapper.yaml")
      .option("detector-config", "FILE",
              "bag: floor detector options, the 'detector' section of this YAML file (e.g. "
              "config/floor_detector.yaml: the building's storey height, floor heights); "
              "default: built-in defaults")
      .option("odometry", "simulated|recorded|stream",
              "log: odometry simulated from its poses, the pose on each laser line, or its ODOM "
              "lines at each scan's stamp (as live); a bag's is recorded",
              "simulated")
      .option("odometry-noise", "T,R,F",
              "simulated odometry noise: translation sigma per metre (fraction), heading sigma "
              "in degrees per metre, heading sigma per radian turned (fraction)",
              "0.05,2,0.02")
      .option("seed", "N", "seed of the simulated odometry noise", "1")
      .option("reference", "LOG",
              "log of the same scans whose poses are the reference (for a bag: matched by stamp, "
              "e.g. the log `storey convert` made it from)")
      .option("robot", "NAME",
              "bag: the robot whose scans are mapped (needed when the bag holds several)")
      .option("truth", "CSV",
              "bag: ground truth (trajectory.csv of `storey simulate`, or its folder)")
      .option("max-scans", "N", "use only the first N scans (0: all)", "0")
      .flag("no-loop-closure", "disable loop closure")
      .flag("no-reference-check",
            "skip checking the reference poses against their own scans (the relation error is "
            "then printed only over all pairs)")
      .flag("quiet", "log warnings only");
  if (!args.parse()) return 0;
  const std::string log_path = args.positional(0, "LOG");
  const bool check_reference = !args.flagSet("no-reference-check");
  const std::string out_dir = args.get("output");
  const std::string odometry_source = args.get("odometry");
  if (odometry_source != "simulated" && odometry_source != "recorded" &&
      odometry_source != "stream")
    throw UsageError("--odometry must be simulated, recorded or stream");
  const auto noise_values = parseList(args.get("odometry-noise"), 3, "odometry-noise");
  eval::OdometryNoise noise;
  noise.translation_fraction = noise_values[0];
  noise.rotation_per_meter = noise_values[1] * M_PI / 180.0;
  noise.rotation_fraction = noise_values[2];
  const long seed = args.getInt("seed");
  const long max_scans = args.getInt("max-scans");
  if (args.flagSet("quiet")) common::setLogLevel(common::LogLevel::kWarn);

  // The floor mapper's file: the shipped one unless --config names another.
  const std::string config_path =
      args.has("config") ? args.get("config")
                         : tools::parameterFilePath(tools::defaultConfigDir(), "floor_mapper");
  const common::ConfigNode root = common::ConfigNode::loadFile(config_path);
  mapping::FloorSlamOptions options = mapping::readFloorSlamOptions(root.child("slam"));
  // A bag's: how far a scan's odometry may be.
  const mapping::InputSequencerOptions sequencing = mapping::readInputSequencerOptions(root);
  if (args.flagSet("no-loop-closure")) options.loop_closure.enabled = false;

  // A bag is a folder (metadata.yaml and .db3 files) or one .db3 file; a `storey simulate`
  // output folder holds one in bag/, with the ground truth beside it.
  std::string bag_path, truth_path;
  if (args.has("truth")) truth_path = args.get("truth");
  if (std::filesystem::is_directory(std::filesystem::path(log_path) / "bag")) {
    bag_path = (std::filesystem::path(log_path) / "bag").string();
    const auto truth = std::filesystem::path(log_path) / "ground_truth";
    if (truth_path.empty() && std::filesystem::exists(truth / "trajectory.csv"))
      truth_path = truth.string();
  } else if (std::filesystem::is_directory(log_path) ||
             std::filesystem::path(log_path).extension() == ".db3") {
    bag_path = log_path;
  }
  const bool from_bag = !bag_path.empty();
  if (from_bag && args.has("reference") && !truth_path.empty())
    throw UsageError("give a bag's reference once: --truth or --reference");
  if (!from_bag && !truth_path.empty())
    throw UsageError("--truth is for bags; a log's is --reference");
  if (!from_bag && args.has("robot")) throw UsageError("--robot is for bags");
  if (!from_bag && args.has("detector-config"))
    throw UsageError("--detector-config is for bags: a log has no pressure to detect rides in");
  detection::FloorDetectorOptions detector_options;
  if (args.has("detector-config"))
    detector_options = detection::loadFloorDetectorOptions(args.get("detector-config"));
  if (from_bag && args.has("odometry") && odometry_source != "recorded")
    throw UsageError(
        "--odometry " + odometry_source +
        " is for logs; a bag's odometry is recorded (interpolated at each scan's stamp)");
  const SlamInput input =
      from_bag
          ? bagInput(bag_path, args.has("robot") ? args.get("robot") : "", truth_path,
                     args.has("reference") ? args.get("reference") : "", max_scans, sequencing,
                     detector_options)
          : logInput(log_path, odometry_source, noise, args.get("odometry-noise"),
                     static_cast<std::uint64_t>(seed),
                     args.has("reference") ? args.get("reference") : "", max_scans, sequencing);
  const std::vector<sensor::LaserScan>& scans = input.scans;
  const std::vector<Pose2>& odometry = input.odometry;
  const std::vector<Pose2>& reference = input.reference;
  const double duration = input.duration;
  if (changesFloor(input.floor_events)) return mapFloors(options, input, out_dir);

  mapping::FloorSlam slam(options, "robot", 0, 0, 0.0);
  const eval::OfflineRun run = eval::runOffline(slam, scans, odometry);

  // Express the result in the log's frame (the front end starts at the origin).
  const Pose2 to_log = odometry.front();
  graph::PoseGraph out_graph = slam.poseGraph();
  for (std::size_t i = 0; i < out_graph.numNodes(); ++i)
    out_graph.setPoseAt(i, to_log * out_graph.nodes()[i].pose);
  floor::FloorGraph fg = slam.floorGraph();
  for (auto& n : fg.nodes) n.pose = to_log * n.pose;
  writeGraphAndMap(out_graph, fg, out_dir);
  std::vector<Pose2> trajectory;
  {
    std::ofstream csv(out_dir + "/trajectory.csv");
    csv << "stamp,x,y,theta,status\n" << std::setprecision(10);
    for (std::size_t i = 0; i < run.trajectory.size(); ++i) {
      trajectory.push_back(to_log * run.trajectory[i]);
      const Pose2& p = trajectory.back();
      csv << scans[i].stamp << ',' << p.x() << ',' << p.y() << ',' << p.theta() << ','
          << mapping::scanStatusName(run.status[i]) << '\n';
    }
  }

  const auto& st = slam.stats();
  std::ostringstream report;
  report << input.source << "\n"
         << "scans: " << scans.size() << "  nodes: " << st.nodes << "  skipped: " << st.skipped
         << "  rejected: " << st.rejected << "  matched: " << st.matched
         << "  match failures: " << st.match_failures << "  retry matches: " << st.retry_matches
         << "  odometry disagreed: " << st.disagreeing_matches
         << " (caught up: " << st.caught_up_matches << ")"
         << "  successor matches: " << st.successor_matches
         << "\nloop closures: " << st.loop_closures << " of " << st.loop_attempts << " attempts ("
         << st.loop_rejected_inconsistent << " rejected as inconsistent, " << st.loop_ambiguous
         << " ambiguous; " << st.loop_maps_built
         << " candidate maps built), optimisations: " << st.optimizations << "\n";
  report << std::fixed << std::setprecision(2) << "processing: " << run.seconds << " s";
  if (duration > 0.0) report << "  log duration: " << duration << " s  real-time factor: " << duration / run.seconds;
  else report << "  log duration: unknown (bad stamps)  scans/s: " << scans.size() / run.seconds;
  report << "\n";
  report << "odometry: " << input.odometry_note << "\n";
  // The odometry model the run's own graph suggests, for a robot whose odometry_noise is not
  // calibrated yet (it sets the odometry edges' weight and max_tracking_chi2's gate).
  printOdometryFit(report, "the finished graph", eval::fitOdometryNoise(fg, options.odometry),
                   options.odometry);
  if (!reference.empty()) {
    // The estimate's and the odometry's relation errors, over the pairs without a left-out pose.
    auto printRelations = [&](const std::vector<bool>& left_out) {
      const eval::RelationErrors errors = eval::relationErrors(trajectory, reference, 10.0, 5000, 1, left_out);
      const eval::RelationErrors odo = eval::relationErrors(odometry, reference, 10.0, 5000, 1, left_out);
      printStats(report, "slam     nearby", errors.nearby);
      printStats(report, "slam     far   ", errors.far);
      printStats(report, "odometry nearby", odo.nearby);
      printStats(report, "odometry far   ", odo.far);
    };
    report << "relation error (Kümmerle et al. 2009) against the reference poses:\n";
    printRelations({});
    if (check_reference) {
      const std::vector<eval::ReferencePoseCheck> checks = eval::checkReferencePoses(scans, reference);
      std::vector<bool> contradicted(reference.size(), false);
      std::size_t count = 0;
      std::ofstream csv(out_dir + "/reference_check.csv");
      csv << "scan,contradicted,matched,reference_score,match_score,offset_x,offset_y,offset_theta\n"
          << std::setprecision(6);
      for (const auto& c : checks) {
        contradicted[c.index] = c.contradicted;
        count += c.contradicted ? 1 : 0;
        const Pose2 offset = reference[c.index].between(c.match);
        csv << c.index << ',' << (c.contradicted ? 1 : 0) << ',' << (c.matched ? 1 : 0) << ',' << c.reference_score
            << ',' << c.match_score << ',';
        if (c.matched) csv << offset.x() << ',' << offset.y() << ',' << offset.theta() << '\n';
        else csv << ",,\n";
      }
      report << "reference poses their own scans contradict: " << count << " of " << reference.size()
             << " (reference_check.csv); the relation error without the pairs that use them:\n";
      printRelations(contradicted);
    }
    // The k-th scan that became a node is node k (one floor, no relocalisation here).
    std::map<int, Pose2> node_reference;
    for (std::size_t i = 0, k = 0; i < run.status.size(); ++i)
      if (run.status[i] == mapping::ScanStatus::kNode && k < slam.floorGraph().nodes.size())
        node_reference[slam.floorGraph().nodes[k++].id] = reference[i];
    writeLoopAttempts(out_dir + "/loop_closures.csv", slam.loopAttempts(), &node_reference);
    printOdometryFit(report, "the reference",
                     eval::fitOdometryNoise(slam.floorGraph(), node_reference, options.odometry),
                     options.odometry);
    report << "edges against the reference (NEES: 3 when an edge's covariance is right):\n";
    for (const auto& c : eval::edgeConsistency(slam.floorGraph(), node_reference))
      report << "  " << std::left << std::setw(13) << floor::edgeKindName(c.kind) << std::right << " "
             << std::setw(5) << c.count << "  NEES " << std::setprecision(2) << c.mean_nees << std::setprecision(4)
             << "  rms error " << c.rms_translation_error << " m " << c.rms_rotation_error * 180.0 / M_PI
             << " deg  rms sigma " << c.rms_translation_sigma << " m " << c.rms_rotation_sigma * 180.0 / M_PI
             << " deg\n";
  }
  std::cout << report.str();
  std::ofstream(out_dir + "/report.txt") << report.str();
  std::cout << "wrote " << out_dir << "/{graph.g2o,map.pgm,map.yaml,map.png,trajectory.csv,report.txt";
  if (!reference.empty()) std::cout << ",loop_closures.csv" << (check_reference ? ",reference_check.csv" : "");
  std::cout << "}\n";
  return 0;
}

}  // namespace storey::cli
