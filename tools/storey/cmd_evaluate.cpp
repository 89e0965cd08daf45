// storey evaluate RESULT_DIR GROUND_TRUTH_DIR: compares an estimated building trajectory
// with the simulator's ground truth (metrics in storey::eval, format in docs/simulator.md).
#include <filesystem>
#include <fstream>
#include <iostream>
#include <sstream>

#include "args.h"
#include "storey/eval/corridors.h"
#include "storey/common/config.h"
#include "storey/eval/metrics.h"

namespace storey::cli {

extern const char* const summary_evaluate =
    "compare an estimated trajectory with ground truth (alignment, ATE, corridors, relations)";

namespace {

namespace fs = std::filesystem;

// A folder holding trajectory.csv, or the file itself.
std::string trajectoryFile(const std::string& path, const std::string& what) {
  if (fs::is_regular_file(path)) return path;
  const fs::path inside = fs::path(path) / "trajectory.csv";
  if (fs::is_regular_file(inside)) return inside.string();
  throw UsageError(what + " " + path + " holds no trajectory.csv");
}

}  // namespace

int run_evaluate(Args& args) {
  args.usage("RESULT_DIR GROUND_TRUTH_DIR",
             "RESULT_DIR holds trajectory.csv (stamp,robot,floor,x,y,theta,z: estimated poses in\n"
             "the building frame at ground-truth stamps, or between them: they are interpolated).\n"
             "GROUND_TRUTH_DIR is the ground_truth folder written by `storey simulate` (or the\n"
             "simulate output folder holding it). Prints per-floor alignment error (after one\n"
             "global SE(2) fit, the residual rigid transform of each floor), per-floor ATE,\n"
             "corridor length ratios (corridors.yaml) and the relation-based error.")
      .option("json", "FILE", "also write the figures as JSON")
      .option("relation-steps", "N,M", "relations between poses N, M... apart", "1,10")
      .option("max-gap", "SECONDS", "interpolate estimates at most this far apart", "1.0");
  if (!args.parse()) return 0;
  const std::string result_dir = args.positional(0, "RESULT_DIR");
  std::string truth_dir = args.positional(1, "GROUND_TRUTH_DIR");
  if (args.positionals().size() > 2) throw UsageError("too many arguments (see --help)");
  if (fs::is_directory(fs::path(truth_dir) / "ground_truth"))
    truth_dir = (fs::path(truth_dir) / "ground_truth").string();

  eval::EvaluateOptions options;
  options.max_gap = args.getDouble("max-gap");
  if (!(options.max_gap > 0.0)) throw UsageError("--max-gap must be positive");
  options.relation_steps.clear();
  {
    std::stringstream in(args.get("relation-steps"));
    std::string item;
    while (std::getline(in, item, ',')) {
      int step = 0;
      try {
        step = std::stoi(item);
      } catch (const std::exception&) {
        throw UsageError("--relation-steps expects integers, got '" + item + "'");
      }
      if (step < 1) throw UsageError("--relation-steps must be positive");
      options.relation_steps.push_back(step);
    }
  }

  const auto estimate = eval::readTrajectoryCsv(trajectoryFile(result_dir, "RESULT_DIR"));
  const auto truth = eval::readTrajectoryCsv(trajectoryFile(truth_dir, "GROUND_TRUTH_DIR"));
  const auto corridors = eval::readCorridors((fs::path(truth_dir) / "corridors.yaml").string());
  const eval::Evaluation evaluation = eval::evaluate(estimate, truth, corridors, options);
  std::cout << eval::toTable(evaluation);
  if (args.has("json")) {
    std::ofstream out(args.get("json"));
    out << eval::toJson(evaluation);
    if (!out) throw std::runtime_error("cannot write " + args.get("json"));
  }
  return 0;
}

}  // namespace storey::cli
