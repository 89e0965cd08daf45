#include "storey/tools/map_job.h"

#include <chrono>
#include <cmath>
#include <filesystem>
#include <iostream>
#include <limits>
#include <optional>
#include <set>
#include <sstream>

#include "storey/catalog/all_components.h"
#include "storey/common/config.h"
#include "storey/common/log.h"
#include "storey/eval/corridors.h"
#include "storey/eval/trajectory.h"
#include "storey/floor_mapper/floor_mapper_component.h"
#include "storey/graph_server/graph_server.h"
#include "storey/runtime/component_registry.h"
#include "storey/runtime/context.h"
#include "storey/runtime/floor_event_conversions.h"
#include "storey/runtime/sensor_bag.h"
#include "storey/runtime/sensor_conversions.h"
#include "storey/runtime/subscription.h"
#include "storey/sim/ground_truth.h"
#include "storey/sim/scenario.h"
#include "storey/sim/simulator.h"
#include "storey/tools/replay.h"
#include "storey/tools/robot_setup.h"
#include "storey/tools/simulation_bag.h"
#include "storey_msgs/msg/FloorEventPubSubTypes.h"

namespace storey::tools {
namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

namespace {

double secondsSince(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

bool isYamlFile(const std::string& path) {
  const std::string ext = fs::path(path).extension().string();
  return fs::is_regular_file(path) && (ext == ".yaml" || ext == ".yml");
}

// Parameters of one component: its shipped file with this run's values set on top.
common::ConfigNode componentParameters(const std::string& config_dir, const std::string& kind,
                                       const std::function<void(YAML::Node&)>& overrides) {
  YAML::Node parameters = parameterFile(config_dir, kind);
  overrides(parameters);
  return common::ConfigNode(parameters, parameterFilePath(config_dir, kind), "");
}

// Floor ids and heights (m) a per-floor input may give.
constexpr int kFloorIds[2] = {-1000, 1000};
constexpr double kFloorHeights[2] = {-1000.0, 10000.0};

struct PreparedInput {
  std::string recording;  // bag folder or log file
  std::string robot;      // CARMEN logs: the robot name used for it
  std::optional<int> floor;
  std::optional<double> height;
};

// The summary's warning for a robot most of whose scans were not mapped (more than half:
// its floors' maps then hold less than they miss); none otherwise.
std::optional<std::string> unmappedScansWarning(const std::string& robot,
                                                const floor_mapper::ScanCounts& c) {
  if (c.received == 0 || 2 * c.notMapped() <= c.received) return std::nullopt;
  std::ostringstream w;
  w << robot << ": " << c.notMapped() << " of its " << c.received << " scans were not mapped (";
  if (c.without_odometry > 0)
    w << c.without_odometry << " without odometry within max_odometry_gap"
      << (c.rejected > 0 ? ", " : "");
  if (c.rejected > 0) w << c.rejected << " rejected by the front end";
  w << "): its floors' maps miss most of what it saw";
  return w.str();
}

}  // namespace

std::string defaultConfigDir() {
  const fs::path source = fs::path(STOREY_SOURCE_DIR) / "config";
  if (fs::exists(source / "buildings")) return source.string();
  return (fs::path(STOREY_INSTALLED_DATA_DIR) / "config").string();
}

std::string defaultBuilding(const std::string& config_dir) {
  return (fs::path(config_dir) / "buildings" / "small2.yaml").string();
}

MapInput parseMapInput(const std::string& text) {
  MapInput input;
  const auto at = text.rfind('@');
  if (at == std::string::npos || fs::exists(text)) {
    input.path = text;
    return input;
  }
  input.path = text.substr(0, at);
  const std::string spec = text.substr(at + 1);
  const auto colon = spec.find(':');
  try {
    std::size_t used = 0;
    const std::string floor_text = spec.substr(0, colon);
    input.floor = std::stoi(floor_text, &used);
    if (used != floor_text.size()) throw std::invalid_argument(floor_text);
    if (colon != std::string::npos) {
      const std::string height_text = spec.substr(colon + 1);
      input.height = std::stod(height_text, &used);
      if (used != height_text.size()) throw std::invalid_argument(height_text);
    }
  } catch (const std::exception&) {
    throw std::invalid_argument("'" + text + "': expected PATH@FLOOR or PATH@FLOOR:HEIGHT");
  }
  if (*input.floor < kFloorIds[0] || *input.floor > kFloorIds[1])
    throw std::invalid_argument("'" + text + "': floor " + std::to_string(*input.floor) +
                                " is outside [" + std::to_string(kFloorIds[0]) + ", " +
                                std::to_string(kFloorIds[1]) + "]");
  if (input.height && !(*input.height >= kFloorHeights[0] && *input.height <= kFloorHeights[1]))
    throw std::invalid_argument("'" + text + "': height " + spec.substr(colon + 1) +
                                " is not a number in [" + common::str(kFloorHeights[0]) + ", " +
                                common::str(kFloorHeights[1]) + "] m");
  return input;
}

std::vector<MapInput> readMapInputs(const std::string& yaml_path) {
  const auto root = common::ConfigNode::loadFile(yaml_path);
  std::vector<MapInput> inputs;
  std::set<int> floors;
  for (const auto& entry : root.sequence("floors")) {
    MapInput input;
    const fs::path path = entry.get<std::string>("path");
    input.path = (path.is_absolute() ? path : fs::path(yaml_path).parent_path() / path).string();
    input.floor = entry.getInt("floor", kFloorIds[0], kFloorIds[1]);
    input.height = entry.getDouble("height", kFloorHeights[0], kFloorHeights[1]);
    input.robot = entry.get<std::string>("robot", "");
    if (!floors.insert(*input.floor).second) entry.fail("floor", "floor listed twice");
    if (!fs::exists(input.path)) entry.fail("path", "no such file or folder: " + input.path);
    entry.finish();
    inputs.push_back(input);
  }
  root.finish();
  if (inputs.empty()) root.fail("floors", "no floors listed");
  return inputs;
}

RobotFloors readRobotFloors(const std::string& yaml_path) {
  const auto root = common::ConfigNode::loadFile(yaml_path);
  RobotFloors out;
  out.path = yaml_path;
  out.heights = root.getDoubles("floor_heights");
  if (out.heights.empty()) root.fail("floor_heights", "no floor heights listed");
  for (std::size_t i = 0; i < out.heights.size(); ++i) {
    if (!std::isfinite(out.heights[i])) root.fail("floor_heights", "height " + std::to_string(i) + " is not finite");
    if (i > 0 && !(out.heights[i] > out.heights[i - 1]))
      root.fail("floor_heights", "heights must increase (floor " + std::to_string(i) + ")");
  }
  const auto robots = root.child("robots");
  if (!robots.isMap() || robots.keys().empty()) root.fail("robots", "a map of robot name -> {start_floor}");
  for (const auto& name : robots.keys()) {
    const auto robot = robots.child(name);
    out.start_floor[name] = robot.getInt("start_floor", 0, static_cast<int>(out.heights.size()) - 1);
    robot.finish();
  }
  robots.finish();
  root.finish();
  return out;
}

MapJobResult runMapJob(const MapJobOptions& options) {
  const auto job_start = Clock::now();
  MapJobResult result;
  result.output_dir = options.output_dir;
  const std::string config_dir = options.config_dir.empty() ? defaultConfigDir() : options.config_dir;
  fs::create_directories(options.output_dir);
  auto say = [&](const std::string& text) {
    if (!options.quiet) std::cout << text << std::endl;
  };

  // 1. Recordings: simulate scenarios first.
  std::vector<MapInput> inputs = options.inputs;
  if (inputs.empty()) inputs.push_back({defaultBuilding(config_dir), {}, {}, ""});
  std::vector<PreparedInput> prepared;
  std::string ground_truth_dir;
  std::vector<eval::CorridorSpec> corridors;
  // Simulated robots: floor_mapper parameters that suit their sensors; fleets (simulated,
  // or recorded with a robots file): floor heights and start floors.
  RobotSetup setup;
  auto phase_start = Clock::now();
  for (std::size_t k = 0; k < inputs.size(); ++k) {
    const MapInput& input = inputs[k];
    if (!fs::exists(input.path)) throw std::runtime_error(input.path + ": no such file or folder");
    PreparedInput p;
    p.floor = input.floor;
    p.height = input.height;
    if (isYamlFile(input.path)) {
      if (inputs.size() > 1) throw std::invalid_argument(input.path + ": a simulated building must be the only input");
      const sim::Scenario scenario = sim::loadScenario(input.path);
      say("simulating " + scenario.name + " (seed " + std::to_string(options.seed) + ")");
      sim::SimulateOptions simulate_options;
      simulate_options.seed = options.seed;
      simulate_options.without_barometer = options.without_barometer;
      const sim::Simulation run = sim::simulate(scenario, simulate_options);
      const fs::path recording = fs::path(options.output_dir) / "recording";
      fs::remove_all(recording);
      fs::create_directories(recording);
      writeSimulationBag(run, (recording / "bag").string());
      sim::writeGroundTruth(run, (recording / "ground_truth").string());
      ground_truth_dir = (recording / "ground_truth").string();
      result.ground_truth_dir = ground_truth_dir;
      corridors = eval::readCorridors((recording / "ground_truth" / "corridors.yaml").string());
      result.scenario = scenario.name;
      setup = robotSetup(scenario);
      p.recording = (recording / "bag").string();
    } else {
      p.recording = input.path;
      p.robot = !input.robot.empty() ? input.robot
                : input.floor         ? "floor" + std::to_string(*input.floor)
                                      : "robot";
    }
    prepared.push_back(p);
  }
  result.timings.push_back({"simulate", secondsSince(phase_start)});

  // 2. Robots and which of them need floor detection; their topics as configured.
  const runtime::SensorTopics topics = sensorTopics(config_dir);
  std::vector<std::string> robots;
  std::map<std::string, const PreparedInput*> robot_input;
  // What each robot carries decides its floor detector: pressure, else the IMU (with the
  // odometry), else none (the robot's recording is one floor).
  std::set<std::string> without_height;
  for (const auto& p : prepared) {
    std::vector<std::string> found;
    std::string not_read;  // a bag's topics of other names or types
    std::map<std::string, runtime::SensorBagReader::Sensors> sensors;
    if (isCarmenLog(p.recording)) {
      found = {p.robot};
      sensors[p.robot].scan = sensors[p.robot].odometry = true;
    } else {
      const runtime::SensorBagReader reader(p.recording, topics);
      for (const auto& t : reader.stats().skipped_topics)
        not_read += (not_read.empty() ? "" : ", ") + t;
      // A robot is mapped from its scans and odometry: one lacking either is left out.
      for (const auto& r : reader.robots()) {
        sensors[r] = reader.sensorsOf(r);
        if (sensors[r].scan && sensors[r].odometry) {
          found.push_back(r);
          continue;
        }
        const std::string missing = sensors[r].scan ? "odometry" : "scans";
        common::logWarn(
            common::str(p.recording, ": robot '", r, "' has no ", missing, " topic: not mapped"));
        not_read += common::str(not_read.empty() ? "" : ", ", "robot '", r, "' without ", missing);
      }
    }
    if (found.empty())
      throw std::runtime_error(p.recording + ": no robot with both scans and odometry found" +
                               (not_read.empty()
                                    ? ""
                                    : " (topics not read: " + not_read +
                                          "; floor_mapper.yaml's and floor_detector.yaml's "
                                          "scan_topic and odom_topic name a robot's topics)"));
    for (const auto& r : found) {
      if (robot_input.count(r)) throw std::invalid_argument("robot '" + r + "' appears in two inputs");
      robots.push_back(r);
      robot_input[r] = &p;
      if (p.floor || sensors[r].pressure) continue;
      if (sensors[r].imu) {
        setup.without_barometer.insert(r);
        say("robot " + r +
            ": no barometer in the recording; floor changes from its IMU and odometry");
      } else {
        without_height.insert(r);
        say("robot " + r + ": no barometer or IMU in the recording; mapped as one floor");
      }
    }
  }

  // A recorded fleet's floors: every recorded robot, and only those, with its start floor.
  if (options.robot_floors) {
    const RobotFloors& given = *options.robot_floors;
    if (!setup.start_floor.empty())
      throw std::invalid_argument(given.path + ": a simulated building gives its robots' floors itself");
    for (const auto& robot : robots) {
      if (robot_input[robot]->floor)
        throw std::invalid_argument(given.path + ": robot '" + robot + "' is recorded on one floor (" +
                                    robot_input[robot]->recording + "@floor); give its floor there only");
      if (!given.start_floor.count(robot))
        throw std::invalid_argument(given.path + ": robot '" + robot + "' of " + robot_input[robot]->recording +
                                    " has no start_floor");
    }
    for (const auto& [robot, floor] : given.start_floor) {
      if (!robot_input.count(robot)) {
        std::string recorded;
        for (const auto& r : robots) recorded += (recorded.empty() ? "" : ", ") + r;
        throw std::invalid_argument(
            common::str(given.path, ": robot '", robot, "' is not in the recordings (they hold ", recorded, ")"));
      }
      setup.start_floor[robot] = floor;
    }
    setup.floor_heights = given.heights;
  }
  // Floors recorded on their own: each mapper starts on its floor. (A floor event instead
  // is ordered by stamp among the log's scans, and a scan stamped no later than the event
  // would land on the initial floor.)
  for (const auto& robot : robots) {
    const PreparedInput& p = *robot_input[robot];
    if (p.floor) setup.recorded_floor[robot] = {*p.floor, p.height.value_or(0.0)};
    if (without_height.count(robot)) setup.recorded_floor[robot] = {0, 0.0};
  }

  // 3. The components, all in this process.
  runtime::ContextOptions context_options;
  context_options.domain_id = options.domain_id;
  context_options.participant_name = "storey_map";
  // Offline: nothing else on the domain may feed the components or hear them.
  context_options.isolated = true;
  runtime::Context context(context_options);
  runtime::ComponentRegistry registry;
  catalog::registerStoreyComponents(registry);
  std::vector<std::unique_ptr<runtime::Component>> pipeline;  // in data-flow order
  graph_server::GraphServer* server = nullptr;
  const std::string journal = (fs::path(options.output_dir) / "journal.bin").string();
  fs::remove(journal);
  // The rides each detector reports, for the report's timeline (delivered on the executor,
  // which this thread drains).
  RobotRides rides;
  std::vector<std::shared_ptr<
      runtime::Subscription<storey_msgs::msg::FloorEvent, storey_msgs::msg::FloorEventPubSubType>>>
      ride_readers;
  for (const auto& robot : robots) {
    if (!robot_input[robot]->floor && !without_height.count(robot)) {
      const YAML::Node parameters = floorDetectorParameters(config_dir, robot, setup);
      pipeline.push_back(registry.create(
          "floor_detector", context,
          common::ConfigNode(parameters, parameterFilePath(config_dir, "floor_detector"), ""),
          "floor_detector_" + robot));
      ride_readers.push_back(
          std::make_shared<runtime::Subscription<storey_msgs::msg::FloorEvent,
                                                 storey_msgs::msg::FloorEventPubSubType>>(
              context, runtime::robotTopic(robot, parameters["events_topic"].as<std::string>()),
              runtime::TopicKind::kGraph,
              [&rides, robot, started = std::optional<floor::FloorEvent>()](
                  const storey_msgs::msg::FloorEvent& m) mutable {
                floor::FloorEvent e = runtime::fromMessage(m);
                if (e.type == floor::FloorEventType::kTransitStarted) started = e;
                if (e.type != floor::FloorEventType::kTransitEnded) return;
                if (started) {  // the message of an arrival names neither its start nor its origin
                  e.start_stamp = started->stamp;
                  e.from_height = started->from_height;
                }
                started.reset();
                rides[robot].push_back(e);
              }));
    }
  }
  for (const auto& robot : robots) {
    pipeline.push_back(
        registry.create("floor_mapper", context,
                        common::ConfigNode(floorMapperParameters(config_dir, robot, setup),
                                           parameterFilePath(config_dir, "floor_mapper"), ""),
                        "floor_mapper_" + robot));
  }
  pipeline.push_back(registry.create("floor_matcher", context,
                                     componentParameters(config_dir, "floor_matcher",
                                                         [&](YAML::Node& n) {
                                                           if (n["floor_matcher"]) n["floor_matcher"]["seed"] = options.seed;
                                                           // Match once, on the final floor graphs, when
                                                           // flushed: matching while graphs grow would
                                                           // depend on thread timing, and the same input
                                                           // and seed must give the same building.
                                                           n["match_while_growing"] = false;
                                                           n["match_after_idle"] = 0.0;
                                                         }),
                                     "floor_matcher"));
  pipeline.push_back(registry.create("graph_server", context,
                                     componentParameters(config_dir, "graph_server",
                                                         [&](YAML::Node& n) { n["journal"] = journal; }),
                                     "graph_server"));
  server = dynamic_cast<graph_server::GraphServer*>(pipeline.back().get());
  for (auto& component : pipeline) component->configure();
  for (auto& component : pipeline) component->activate();

  // 4. Replay every recording. After each message the executor is drained, so every
  // component has seen everything up to that stamp before the next one: as fast as the
  // subscribers take it, and the same order every run.
  phase_start = Clock::now();
  std::uint64_t messages = 0;
  std::vector<std::string> warnings;  // for the log and the report's summary
  for (const auto& p : prepared) {
    ReplayOptions replay_options;
    replay_options.settle_seconds = 0.0;
    replay_options.log_robot = p.robot;
    replay_options.topics = topics;
    replay_options.after_each = [&context] {
      context.executor().drain();
      context.executor().drain();  // what the first drain's tasks published
    };
    SensorReplayer replayer(context, replay_options);
    auto source = openSensorSource(p.recording, replay_options);
    const ReplaySummary summary = replayer.replay(*source);
    if (summary.total > 0 && summary.last_stamp > summary.first_stamp)
      result.recording_seconds += summary.last_stamp - summary.first_stamp;
    messages += summary.total;
    // Data left out is reported even with --quiet.
    if (summary.skipped) {
      const std::string note = source->skippedNote();
      common::logWarn(!note.empty()
                          ? note
                          : p.recording + ": " + std::to_string(summary.skipped) +
                                " records skipped (unreadable or of types storey does not use)");
    }
    if (!summary.cut_short.empty()) {
      warnings.push_back("the recording ends early, mapped up to where it is damaged: " +
                         summary.cut_short);
      common::logWarn(warnings.back());
    }
  }
  result.timings.push_back({"replay + detection + mapping", secondsSince(phase_start)});
  say("replayed " + std::to_string(messages) + " messages (" + std::to_string(result.recording_seconds) +
      " s of recording)");

  // 5. Let every component finish, in data-flow order.
  phase_start = Clock::now();
  for (auto& component : pipeline) {
    context.executor().drain();
    if (!component->flush(options.flush_timeout))
      throw std::runtime_error(component->name() + " did not finish within " +
                               std::to_string(options.flush_timeout) + " s");
    context.executor().drain();
  }
  result.timings.push_back({"matching + building optimisation", secondsSince(phase_start)});

  // 6. The building.
  phase_start = Clock::now();
  auto [graph, solution] = server->snapshot();
  for (const auto& component : pipeline)
    if (const auto* mapper =
            dynamic_cast<const floor_mapper::FloorMapperComponent*>(component.get())) {
      if (auto w = unmappedScansWarning(mapper->options().robot, mapper->scanCounts())) {
        common::logWarn(*w);
        warnings.push_back(std::move(*w));
      }
    }
  for (auto it = pipeline.rbegin(); it != pipeline.rend(); ++it) (*it)->shutdown();
  if (graph.empty()) throw std::runtime_error("no floor graph was built: nothing to write");
  ReportExtras extras;
  extras.title = result.scenario.empty() ? "storey building" : "storey building: " + result.scenario;
  for (const auto& input : inputs) extras.input += (extras.input.empty() ? "" : ", ") + input.path;
  extras.recording_seconds = result.recording_seconds;
  extras.rides = std::move(rides);  // known: the detectors ran in this job
  extras.unaligned = solveWithoutConstraints(graph);
  if (!ground_truth_dir.empty()) {
    const auto truth = eval::readTrajectoryCsv((fs::path(ground_truth_dir) / "trajectory.csv").string());
    result.evaluation = eval::evaluate(trajectoryRows(graph, solution), truth, corridors);
    result.evaluation_unaligned = eval::evaluate(trajectoryRows(graph, *extras.unaligned), truth, corridors);
    extras.evaluation = result.evaluation;
    extras.evaluation_unaligned = result.evaluation_unaligned;
  }
  extras.timings = result.timings;
  extras.warnings = std::move(warnings);
  result.outputs = writeBuildingOutputs(options.output_dir, graph, solution, options.outputs, extras);
  result.timings.push_back({"outputs", secondsSince(phase_start)});
  if (options.keep_graph) result.graph = std::make_shared<const building::BuildingGraph>(std::move(graph));
  result.total_seconds = secondsSince(job_start);
  return result;
}

}  // namespace storey::tools
