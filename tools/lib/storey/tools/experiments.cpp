#include "storey/tools/experiments.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <atomic>
#include <chrono>
#include <exception>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <limits>
#include <mutex>
#include <sstream>
#include <stdexcept>
#include <thread>

#include "storey/eval/corridors.h"
#include "storey/runtime/context.h"
#include "storey/sim/scenario.h"
#include "storey/sim/simulator.h"
#include "storey/tools/building_report.h"
#include "storey/tools/map_job.h"

namespace storey::tools {
namespace fs = std::filesystem;

namespace {

constexpr double kDeg = 180.0 / M_PI;
constexpr int kMaxDomain = 232;  // Fast DDS: higher ids give out-of-range ports

// "mean ± std (worst)" of a statistic, scaled.
std::string cell(const Statistic& s, double scale, int precision) {
  if (s.count == 0) return "-";
  return fixedText(s.mean * scale, precision) + " ± " + fixedText(s.std * scale, precision) + " (" +
         fixedText(s.worst * scale, precision) + ")";
}

// The true pose of `robot` at `stamp`, if ground truth has one within the tolerance.
class TruthIndex {
 public:
  explicit TruthIndex(const std::vector<eval::PoseRow>& truth) {
    for (const auto& row : truth) rows_[row.robot].push_back(&row);
    for (auto& [robot, rows] : rows_)
      std::sort(rows.begin(), rows.end(),
                [](const eval::PoseRow* a, const eval::PoseRow* b) { return a->stamp < b->stamp; });
  }
  const eval::PoseRow* at(const std::string& robot, double stamp, double tolerance) const {
    auto it = rows_.find(robot);
    if (it == rows_.end()) return nullptr;
    const auto& rows = it->second;
    auto next = std::lower_bound(rows.begin(), rows.end(), stamp,
                                 [](const eval::PoseRow* r, double s) { return r->stamp < s; });
    const eval::PoseRow* best = nullptr;
    if (next != rows.end()) best = *next;
    if (next != rows.begin()) {
      const eval::PoseRow* before = *std::prev(next);
      if (!best || stamp - before->stamp < best->stamp - stamp) best = before;
    }
    return best && std::abs(best->stamp - stamp) <= tolerance ? best : nullptr;
  }

 private:
  std::map<std::string, std::vector<const eval::PoseRow*>> rows_;
};

const eval::FloorError* findFloor(const eval::Evaluation& e, const std::string& floor) {
  for (const auto& f : e.floors)
    if (f.floor == floor) return &f;
  return nullptr;
}

const eval::CorridorError* findCorridor(const eval::Evaluation& e, const std::string& name) {
  for (const auto& c : e.corridors)
    if (c.name == name) return &c;
  return nullptr;
}

RunFigures runOne(const ExperimentSpec& spec, std::uint64_t seed, int domain,
                  const ExperimentOptions& options, const std::string& building) {
  MapJobOptions job;
  job.inputs = {{building, {}, {}, ""}};
  job.output_dir = (fs::path(options.output_dir) / spec.name / ("seed_" + std::to_string(seed))).string();
  job.seed = seed;
  job.domain_id = domain;
  job.config_dir = options.config_dir;
  job.quiet = true;
  job.keep_graph = true;
  job.without_barometer = options.without_barometer;
  const MapJobResult result = runMapJob(job);
  if (!result.evaluation || !result.evaluation_unaligned || !result.graph || result.ground_truth_dir.empty())
    throw std::runtime_error(spec.name + " seed " + std::to_string(seed) + ": the map job gave no evaluation");
  RunFigures figures;
  figures.experiment = spec.name;
  figures.seed = seed;
  figures.output_dir = result.output_dir;
  figures.seconds = result.total_seconds;
  figures.with = *result.evaluation;
  figures.independent = *result.evaluation_unaligned;
  const fs::path truth_dir = result.ground_truth_dir;
  const auto truth = eval::readTrajectoryCsv((truth_dir / "trajectory.csv").string());
  figures.constraints = checkConstraints(*result.graph, truth, options.goals);
  // The odometry the map job replayed: the simulation is deterministic in its seed.
  const sim::Simulation simulation = sim::simulate(sim::loadScenario(building), seed);
  std::map<std::string, std::vector<sensor::OdometrySample>> odometry;
  for (const auto& robot : simulation.robots) odometry[robot.name] = robot.odometry;
  const auto chained = solveWithOdometryChain(*result.graph, odometry);
  figures.without = eval::evaluate(trajectoryRows(*result.graph, chained), truth,
                                   eval::readCorridors((truth_dir / "corridors.yaml").string()));
  return figures;
}

}  // namespace

const std::vector<ExperimentSpec>& paperExperiments() {
  static const std::vector<ExperimentSpec> experiments = {
      {"tower10", "tower10.yaml", 9, true, {},
       "Fig. 9: the alignment error of every floor falls significantly with inter-floor constraints "
       "(9 experiments, 10 floors)"},
      {"featureless", "featureless.yaml", 10, false, {"corridor_B"},
       "Fig. 10: floor B's corridor 14.2 % (18.5 m) short without inter-floor constraints, 5.8 % "
       "(7.5 m) with them (10 runs)"},
  };
  return experiments;
}

std::vector<ConstraintCheck> checkConstraints(const building::BuildingGraph& graph,
                                              const std::vector<eval::PoseRow>& truth,
                                              const ExperimentGoals& goals, double stamp_tolerance) {
  const TruthIndex index(truth);
  std::vector<ConstraintCheck> checks;
  for (const auto& c : graph.constraints()) {
    ConstraintCheck check;
    check.id = c.id;
    const auto from_graph = graph.floorGraphs().find(c.graph_from);
    const auto to_graph = graph.floorGraphs().find(c.graph_to);
    const floor::FloorNode* from =
        from_graph == graph.floorGraphs().end() ? nullptr : from_graph->second.findNode(c.node_from);
    const floor::FloorNode* to =
        to_graph == graph.floorGraphs().end() ? nullptr : to_graph->second.findNode(c.node_to);
    const eval::PoseRow* truth_from =
        from ? index.at(from_graph->second.robot, from->stamp, stamp_tolerance) : nullptr;
    const eval::PoseRow* truth_to = to ? index.at(to_graph->second.robot, to->stamp, stamp_tolerance) : nullptr;
    if (truth_from && truth_to) {
      check.checked = true;
      check.floor_from = truth_from->floor;
      check.floor_to = truth_to->floor;
      check.judgement =
          matching::judgeConstraint(c.relative, truth_from->pose.between(truth_to->pose), c.information, goals.wrong);
      check.from_x = truth_from->pose.x();
      check.from_y = truth_from->pose.y();
      check.to_x = truth_to->pose.x();
      check.to_y = truth_to->pose.y();
    }
    checks.push_back(check);
  }
  return checks;
}

building::BuildingSolution solveWithOdometryChain(
    const building::BuildingGraph& graph,
    const std::map<std::string, std::vector<sensor::OdometrySample>>& odometry) {
  // The odometry pose at a stamp, interpolated between the samples around it.
  auto odometryAt = [](const std::vector<sensor::OdometrySample>& samples, double stamp) {
    auto next = std::lower_bound(samples.begin(), samples.end(), stamp,
                                 [](const sensor::OdometrySample& s, double t) { return s.stamp < t; });
    if (next == samples.begin()) return next->pose;
    if (next == samples.end()) return samples.back().pose;
    const auto& before = *std::prev(next);
    const double span = next->stamp - before.stamp;
    return geometry::interpolate(before.pose, next->pose, span > 0 ? (stamp - before.stamp) / span : 0.0);
  };
  struct Visit {
    double stamp;
    int graph, node;
  };
  std::map<std::string, std::vector<Visit>> nodes;  // per robot, every node of every graph
  building::BuildingGraph joined;
  for (const auto& [id, fg] : graph.floorGraphs()) {
    joined.upsertFloorGraph(fg);
    for (const auto& n : fg.nodes) nodes[fg.robot].push_back({n.stamp, id, n.id});
  }
  int next_id = 1;
  for (auto& [robot, visits] : nodes) {
    const auto samples = odometry.find(robot);
    if (samples == odometry.end() || samples->second.empty())
      throw std::invalid_argument("no odometry of robot '" + robot + "' to join its floor graphs");
    std::sort(visits.begin(), visits.end(), [](const Visit& a, const Visit& b) { return a.stamp < b.stamp; });
    for (std::size_t i = 1; i < visits.size(); ++i) {
      const Visit &a = visits[i - 1], &b = visits[i];
      if (a.graph == b.graph) continue;
      building::InterGraphConstraint c;
      c.id = next_id++;
      c.graph_from = a.graph;
      c.node_from = a.node;
      c.graph_to = b.graph;
      c.node_to = b.node;
      c.relative = odometryAt(samples->second, a.stamp).inverse() * odometryAt(samples->second, b.stamp);
      c.dz = graph.floorGraphs().at(b.graph).floor_height - graph.floorGraphs().at(a.graph).floor_height;
      // A chain of joins is a tree: any information places the floors exactly where the
      // odometry puts them; it only weighs a join against others when a robot returns.
      c.information = Eigen::Vector3d(100.0, 100.0, 1000.0).asDiagonal();
      joined.addConstraint(c);
    }
  }
  return joined.optimize();
}

Statistic summarise(const std::vector<double>& values) {
  Statistic s;
  s.count = values.size();
  if (values.empty()) return s;
  s.worst = *std::max_element(values.begin(), values.end());
  for (double v : values) s.mean += v;
  s.mean /= static_cast<double>(values.size());
  if (values.size() > 1) {
    double sum = 0.0;
    for (double v : values) sum += (v - s.mean) * (v - s.mean);
    s.std = std::sqrt(sum / static_cast<double>(values.size() - 1));
  }
  return s;
}

ExperimentTable summariseExperiment(const ExperimentSpec& spec, const ExperimentGoals& goals,
                                    std::vector<RunFigures> runs) {
  ExperimentTable table;
  table.spec = spec;
  table.goals = goals;
  std::sort(runs.begin(), runs.end(), [](const RunFigures& a, const RunFigures& b) { return a.seed < b.seed; });
  table.runs = std::move(runs);

  // Floors and corridors in the order the evaluation lists them, over all runs.
  std::vector<std::string> floors, corridors;
  for (const auto& run : table.runs) {
    for (const auto& f : run.with.floors)
      if (std::find(floors.begin(), floors.end(), f.floor) == floors.end()) floors.push_back(f.floor);
    for (const auto* e : {&run.with, &run.without})
      for (const auto& c : e->corridors)
        if (c.measured && std::find(corridors.begin(), corridors.end(), c.name) == corridors.end())
          corridors.push_back(c.name);
    for (const auto& c : run.constraints) {
      ++table.constraints;
      table.wrong += c.judgement.wrong;
      table.off_weak += c.judgement.off && !c.judgement.wrong;
      table.unchecked += !c.checked;
    }
  }

  for (const auto& name : floors) {
    FloorRow row;
    row.floor = name;
    std::vector<double> tw, rw, t, r, counts, constraint_rotation;
    for (const auto& run : table.runs) {
      const auto* with = findFloor(run.with, name);
      const auto* without = findFloor(run.without, name);
      if (with) {
        t.push_back(with->residual_translation);
        r.push_back(with->residual_rotation);
      }
      if (without) {
        tw.push_back(without->residual_translation);
        rw.push_back(without->residual_rotation);
      }
      int count = 0;
      for (const auto& c : run.constraints) {
        if (c.floor_from != name && c.floor_to != name) continue;
        ++count;
        row.wrong += c.judgement.wrong;
        if (c.checked) constraint_rotation.push_back(c.judgement.signed_rotation);
      }
      counts.push_back(count);
    }
    row.translation_without = summarise(tw);
    row.rotation_without = summarise(rw);
    row.translation_with = summarise(t);
    row.rotation_with = summarise(r);
    row.constraints = summarise(counts);
    row.constraint_rotation = summarise(constraint_rotation);
    row.goal_met = row.translation_with.count == table.runs.size() &&
                   row.translation_with.worst <= goals.floor_translation &&
                   row.rotation_with.worst <= goals.floor_rotation;
    table.floors.push_back(row);
  }

  for (const auto& name : corridors) {
    CorridorRow row;
    row.name = name;
    std::vector<double> ew, e, aw, a;
    for (const auto& run : table.runs) {
      const auto* with = findCorridor(run.with, name);
      const auto* without = findCorridor(run.without, name);
      if (with && with->measured) {
        row.floor = with->floor;
        row.true_length = with->true_length;
        e.push_back(with->ratio - 1.0);
        a.push_back(std::abs(with->ratio - 1.0));
      } else {
        ++row.unmeasured;
      }
      if (without && without->measured) {
        ew.push_back(without->ratio - 1.0);
        aw.push_back(std::abs(without->ratio - 1.0));
      }
    }
    row.error_without = summarise(ew);
    row.error_with = summarise(e);
    row.abs_error_without = summarise(aw);
    row.abs_error_with = summarise(a);
    row.goal = std::find(spec.goal_corridors.begin(), spec.goal_corridors.end(), name) != spec.goal_corridors.end();
    row.goal_met = row.goal && row.unmeasured == 0 && row.abs_error_with.worst < goals.corridor_error;
    table.corridors.push_back(row);
  }

  if (spec.floor_goal) {
    std::size_t met = 0;
    const FloorRow* worst = nullptr;
    for (const auto& f : table.floors) {
      met += f.goal_met;
      if (!worst || f.translation_with.worst / goals.floor_translation + f.rotation_with.worst / goals.floor_rotation >
                        worst->translation_with.worst / goals.floor_translation +
                            worst->rotation_with.worst / goals.floor_rotation)
        worst = &f;
    }
    std::string text = "every floor within " + fixedText(goals.floor_translation, 2) + " m / " +
                       fixedText(goals.floor_rotation * kDeg, 1) +
                       " deg in every run: " + std::to_string(met) + " of " +
                       std::to_string(table.floors.size()) + " floors";
    if (worst)
      text += "; worst " + worst->floor + ": " + fixedText(worst->translation_with.worst, 3) +
              " m, " + fixedText(worst->rotation_with.worst * kDeg, 2) + " deg";
    table.verdicts.push_back({text, !table.floors.empty() && met == table.floors.size()});
  }
  for (const auto& goal : spec.goal_corridors) {
    const CorridorRow* row = nullptr;
    for (const auto& c : table.corridors)
      if (c.name == goal) row = &c;
    std::string text = goal + " length error below " + fixedText(goals.corridor_error * 100, 1) +
                       " % in every run: ";
    if (!row) {
      table.verdicts.push_back({text + "never measured", false});
      continue;
    }
    text += "mean |error| " + fixedText(row->abs_error_with.mean * 100, 2) + " %, worst " +
            fixedText(row->abs_error_with.worst * 100, 2) +
            " % (without inter-floor constraints: mean " +
            fixedText(row->abs_error_without.mean * 100, 2) + " %)";
    if (row->unmeasured) text += ", not measured in " + std::to_string(row->unmeasured) + " runs";
    table.verdicts.push_back({text, row->goal_met});
  }
  table.verdicts.push_back({"no wrong inter-floor constraint: " + std::to_string(table.wrong) + " wrong of " +
                                std::to_string(table.constraints) +
                                (table.unchecked ? " (" + std::to_string(table.unchecked) + " not checkable)" : "") +
                                (table.off_weak ? "; " + std::to_string(table.off_weak) +
                                                      " more are off by over 0.3 m, only along their "
                                                      "weak direction and within 3 of their claimed sigmas"
                                                : ""),
                            table.wrong == 0});
  return table;
}

std::vector<ExperimentTable> runExperiments(const ExperimentOptions& options) {
  const std::string config_dir = options.config_dir.empty() ? defaultConfigDir() : options.config_dir;
  std::vector<const ExperimentSpec*> chosen;
  for (const auto& spec : paperExperiments())
    if (options.experiment == "all" || options.experiment == spec.name) chosen.push_back(&spec);
  // Any other simulated building of config/buildings/ runs the same way, every floor judged
  // against the alignment goal.
  const ExperimentSpec other{options.experiment, options.experiment + ".yaml", 3, true, {}, ""};
  if (chosen.empty() && !options.experiment.empty() && options.experiment.find('/') == std::string::npos &&
      fs::is_regular_file(fs::path(config_dir) / "buildings" / other.building))
    chosen.push_back(&other);
  if (chosen.empty()) {
    std::string names;
    for (const auto& spec : paperExperiments()) names += spec.name + "|";
    throw std::invalid_argument("unknown experiment '" + options.experiment + "' (expected " + names +
                                "all, or the name of a building in " + (fs::path(config_dir) / "buildings").string() +
                                ")");
  }
  if (options.seeds < 0) throw std::invalid_argument("seeds must not be negative");
  if (options.jobs < 1) throw std::invalid_argument("jobs must be at least 1");
  const int base_domain = runtime::resolveDomainId(options.domain_id);
  if (base_domain + options.jobs - 1 > kMaxDomain)
    throw std::invalid_argument("domain " + std::to_string(base_domain) + " + " + std::to_string(options.jobs) +
                                " jobs exceeds the largest DDS domain id, " + std::to_string(kMaxDomain));

  struct Task {
    const ExperimentSpec* spec;
    std::uint64_t seed;
  };
  std::vector<Task> tasks;
  for (const auto* spec : chosen) {
    const std::string building = (fs::path(config_dir) / "buildings" / spec->building).string();
    if (!fs::exists(building)) throw std::runtime_error(building + ": no such scenario file");
    const int seeds = options.seeds > 0 ? options.seeds : spec->default_seeds;
    for (int k = 0; k < seeds; ++k) tasks.push_back({spec, options.first_seed + static_cast<std::uint64_t>(k)});
  }

  fs::create_directories(options.output_dir);
  std::vector<std::optional<RunFigures>> results(tasks.size());
  std::map<const ExperimentSpec*, double> wall;  // per experiment: first start to last end
  std::map<const ExperimentSpec*, std::chrono::steady_clock::time_point> started;
  std::mutex mutex;
  std::atomic<std::size_t> next{0};
  std::exception_ptr failure;
  std::size_t done = 0;
  const auto t0 = std::chrono::steady_clock::now();
  // The tables of the runs done so far, written after every run so that an interrupted
  // experiment still leaves its figures (call with `mutex` held, or after the workers).
  auto collect = [&]() {
    std::vector<ExperimentTable> tables;
    for (const auto* spec : chosen) {
      std::vector<RunFigures> runs;
      for (std::size_t i = 0; i < tasks.size(); ++i)
        if (tasks[i].spec == spec && results[i]) runs.push_back(*results[i]);
      ExperimentTable table = summariseExperiment(*spec, options.goals, std::move(runs));
      table.seconds = wall[spec];
      tables.push_back(std::move(table));
    }
    const auto write = [](const fs::path& path, const std::string& text) {
      std::ofstream out(path);
      out << text;
      if (!out) throw std::runtime_error(path.string() + ": cannot write");
    };
    write(fs::path(options.output_dir) / "experiments.md", toMarkdown(tables));
    write(fs::path(options.output_dir) / "experiments.csv", toCsv(tables));
    write(fs::path(options.output_dir) / "constraints.csv", constraintsCsv(tables));
    return tables;
  };
  auto worker = [&](int domain) {
    for (;;) {
      const std::size_t i = next++;
      if (i >= tasks.size()) return;
      {
        std::lock_guard<std::mutex> lock(mutex);
        if (failure) return;
        started.emplace(tasks[i].spec, std::chrono::steady_clock::now());
      }
      try {
        const std::string building = (fs::path(config_dir) / "buildings" / tasks[i].spec->building).string();
        RunFigures figures = runOne(*tasks[i].spec, tasks[i].seed, domain, options, building);
        std::lock_guard<std::mutex> lock(mutex);
        const auto now = std::chrono::steady_clock::now();
        wall[tasks[i].spec] = std::chrono::duration<double>(now - started[tasks[i].spec]).count();
        ++done;
        if (options.progress) {
          std::size_t wrong = 0;
          for (const auto& c : figures.constraints) wrong += c.judgement.wrong;
          options.progress(
              "[" + std::to_string(done) + "/" + std::to_string(tasks.size()) + "] " +
              figures.experiment + " seed " + std::to_string(figures.seed) + ": " +
              fixedText(figures.seconds, 1) + " s, " + std::to_string(figures.constraints.size()) +
              " inter-floor constraints (" + std::to_string(wrong) + " wrong), ATE " +
              fixedText(figures.without.ate_rmse, 3) + " m -> " +
              fixedText(figures.with.ate_rmse, 3) + " m (" +
              fixedText(std::chrono::duration<double>(now - t0).count(), 0) + " s elapsed)");
        }
        results[i] = std::move(figures);
        try {
          collect();
        } catch (...) {
          failure = std::current_exception();  // `mutex` is held here
          return;
        }
      } catch (...) {
        std::lock_guard<std::mutex> lock(mutex);
        if (!failure) failure = std::current_exception();
        return;
      }
    }
  };
  const int jobs = std::min<int>(options.jobs, static_cast<int>(tasks.size()));
  if (jobs <= 1) {
    worker(base_domain);
  } else {
    std::vector<std::thread> threads;
    for (int k = 0; k < jobs; ++k) threads.emplace_back(worker, base_domain + k);
    for (auto& t : threads) t.join();
  }
  if (failure) std::rethrow_exception(failure);
  return collect();
}

std::string toMarkdown(const std::vector<ExperimentTable>& tables) {
  std::ostringstream out;
  for (const auto& t : tables) {
    out << "## " << t.spec.name << ": " << t.runs.size() << " seeds";
    if (!t.runs.empty()) out << " (" << t.runs.front().seed << "-" << t.runs.back().seed << ")";
    out << ", " << fixedText(t.seconds, 0) << " s\n\n";
    if (t.spec.paper.empty())
      out << "Not one of the paper's experiments: every floor is judged against the alignment goal.\n\n";
    else
      out << "Paper, " << t.spec.paper << ".\n\n";
    out << "Per floor, mean ± std (worst) over seeds: the residual alignment of the floor after one global "
           "fit, without inter-floor constraints (floor graphs joined by odometry only, the paper's baseline) "
           "and with them; constraints touching the floor per run; wrong ones over all runs; the signed heading "
           "error of those constraints against truth (mean ± std, deg).\n\n";
    out << "| floor | without: m | without: deg | with: m | with: deg | constraints | wrong | constraint "
           "deg | goal |\n";
    out << "|---|---|---|---|---|---|---|---|---|\n";
    for (const auto& f : t.floors) {
      out << "| " << f.floor << " | " << cell(f.translation_without, 1, 3) << " | "
          << cell(f.rotation_without, kDeg, 2) << " | " << cell(f.translation_with, 1, 3) << " | "
          << cell(f.rotation_with, kDeg, 2) << " | " << fixedText(f.constraints.mean, 1) << " | "
          << f.wrong << " | "
          << (f.constraint_rotation.count
                  ? fixedText(f.constraint_rotation.mean * kDeg, 2) + " ± " +
                        fixedText(f.constraint_rotation.std * kDeg, 2)
                  : std::string("-"))
          << " | " << (t.spec.floor_goal ? (f.goal_met ? "met" : "**no**") : "-") << " |\n";
    }
    if (!t.corridors.empty()) {
      out << "\nCorridor length error, estimated / true - 1, mean ± std (worst |error|), %:\n\n";
      out << "| corridor | floor | true m | without | with | goal |\n|---|---|---|---|---|---|\n";
      for (const auto& c : t.corridors) {
        auto percent = [](const Statistic& s, const Statistic& abs) {
          if (s.count == 0) return std::string("-");
          return fixedText(s.mean * 100, 2) + " ± " + fixedText(s.std * 100, 2) + " (" +
                 fixedText(abs.worst * 100, 2) + ")";
        };
        out << "| " << c.name << " | " << c.floor << " | " << fixedText(c.true_length, 1) << " | "
            << percent(c.error_without, c.abs_error_without) << " | "
            << percent(c.error_with, c.abs_error_with) << " | "
            << (c.goal ? (c.goal_met ? "met" : "**no**") : "-") << " |\n";
      }
    }
    out << "\nGoals:\n";
    for (const auto& [text, met] : t.verdicts) out << "- " << (met ? "met: " : "**NOT met**: ") << text << "\n";
    out << "\nRuns:";
    for (const auto& r : t.runs)
      out << " seed " << r.seed << " " << fixedText(r.seconds, 0) << " s;";
    out << "\n\n";
  }
  return out.str();
}

std::string toCsv(const std::vector<ExperimentTable>& tables) {
  std::ostringstream out;
  out << std::setprecision(9);
  out << "experiment,seed,kind,name,without_translation_m,without_rotation_deg,with_translation_m,"
         "with_rotation_deg,independent_translation_m,independent_rotation_deg,without_length_error,"
         "with_length_error,constraints,wrong,run_seconds\n";
  for (const auto& t : tables) {
    for (const auto& r : t.runs) {
      for (const auto& f : r.with.floors) {
        const auto* without = findFloor(r.without, f.floor);
        int count = 0, wrong = 0;
        for (const auto& c : r.constraints)
          if (c.floor_from == f.floor || c.floor_to == f.floor) {
            ++count;
            wrong += c.judgement.wrong;
          }
        out << t.spec.name << "," << r.seed << ",floor," << f.floor << ",";
        if (without) out << without->residual_translation << "," << without->residual_rotation * kDeg;
        else out << ",";
        out << "," << f.residual_translation << "," << f.residual_rotation * kDeg << ",";
        if (const auto* independent = findFloor(r.independent, f.floor))
          out << independent->residual_translation << "," << independent->residual_rotation * kDeg;
        else out << ",";
        out << ",,," << count << "," << wrong << "," << r.seconds << "\n";
      }
      for (const auto& c : r.with.corridors) {
        const auto* without = findCorridor(r.without, c.name);
        out << t.spec.name << "," << r.seed << ",corridor," << c.name << ",,,,,,,";
        if (without && without->measured) out << without->ratio - 1.0;
        out << ",";
        if (c.measured) out << c.ratio - 1.0;
        out << ",,," << r.seconds << "\n";
      }
    }
  }
  return out.str();
}

std::string constraintsCsv(const std::vector<ExperimentTable>& tables) {
  std::ostringstream out;
  out << std::setprecision(9);
  out << "experiment,seed,constraint,floor_from,floor_to,checked,translation_error_m,rotation_error_deg,wrong,from_x,from_y,to_x,to_y,weak_sigma_m,along_weak_m,off\n";
  for (const auto& t : tables)
    for (const auto& r : t.runs)
      for (const auto& c : r.constraints)
        out << t.spec.name << "," << r.seed << "," << c.id << "," << c.floor_from << "," << c.floor_to << ","
            << c.checked << "," << c.judgement.translation << "," << c.judgement.signed_rotation * kDeg << ","
            << c.judgement.wrong << "," << c.from_x << "," << c.from_y << "," << c.to_x << "," << c.to_y << ","
            << c.judgement.weak_sigma << "," << c.judgement.along_weak << "," << c.judgement.off << "\n";
  return out.str();
}

}  // namespace storey::tools
