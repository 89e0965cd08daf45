// storey experiments: the paper's experiments (tower10, featureless) as one command. See
// storey/tools/experiments.h.
#include <iostream>

#include "args.h"
#include "storey/common/log.h"
#include "storey/tools/experiments.h"

namespace storey::cli {

extern const char* const summary_experiments =
    "reproduce the paper's experiments (tower10 x 9 seeds, featureless x 10) and print the tables";

int run_experiments(Args& args) {
  args.usage(
          "[--experiment tower10|featureless|all|BUILDING] [--seeds N] [--output DIR]",
          "Runs the main job (`storey map`) on the simulated buildings of the paper's "
          "experiments,\n"
          "once per seed, evaluates every run against ground truth with and without inter-floor\n"
          "constraints and prints the tables:\n"
          "  tower10      per floor, the alignment error (Fig. 9); goal: every floor within\n"
          "               0.05 m / 0.2 deg in every run;\n"
          "  featureless  floor B's corridor length error (Fig. 10; paper: 14.2 % without,\n"
          "               5.8 % with); goal: below 1 % in every run;\n"
          "  BUILDING     any other building of config/buildings/ (e.g. office4, glass3,\n"
          "               corridors3), 3 seeds by default; goal: every floor within\n"
          "               0.05 m / 0.2 deg in every run.\n"
          "Every run's outputs go to DIR/<experiment>/seed_<n>/ (report.html, overlay.png, ...);\n"
          "the tables to DIR/experiments.md and DIR/experiments.csv (one row per run and floor).")
      .option("experiment", "NAME", "tower10, featureless, all, or a building's name", "all")
      .option("seeds", "N", "seeds per experiment (0: the paper's 9 and 10)", "0")
      .option("first-seed", "N", "the first seed", "1")
      .option("output", "DIR", "output folder", "out/experiments")
      .option("config", "DIR", "component parameter files and buildings/", "the shipped config/")
      .option("domain", "ID", "DDS domain id of the first job (default: ROS_DOMAIN_ID, else 0)",
              "-1")
      .option("jobs", "N", "runs at the same time (job k uses domain ID+k)", "1")
      .flag("no-barometer", "the robots carry no barometer (floor changes from the IMU)")
      .flag("verbose", "let the components log their progress");
  if (!args.parse()) return 0;
  tools::ExperimentOptions options;
  options.experiment = args.get("experiment");
  const long seeds = args.getInt("seeds"), first = args.getInt("first-seed"), jobs = args.getInt("jobs");
  if (seeds < 0) throw UsageError("--seeds must not be negative");
  if (first < 0) throw UsageError("--first-seed must not be negative");
  if (jobs < 1) throw UsageError("--jobs must be at least 1");
  options.seeds = static_cast<int>(seeds);
  options.first_seed = static_cast<std::uint64_t>(first);
  options.jobs = static_cast<int>(jobs);
  options.output_dir = args.get("output");
  if (args.has("config")) options.config_dir = args.get("config");
  options.domain_id = static_cast<int>(args.getInt("domain"));
  options.without_barometer = args.flagSet("no-barometer");
  if (!args.flagSet("verbose") && common::logLevel() < common::LogLevel::kWarn)
    common::setLogLevel(common::LogLevel::kWarn);
  options.progress = [](const std::string& line) { std::cerr << line << std::endl; };
  const auto tables = tools::runExperiments(options);
  std::cout << tools::toMarkdown(tables);
  std::cout << "tables: " << options.output_dir << "/experiments.md, " << options.output_dir
            << "/experiments.csv\n";
  return 0;
}

}  // namespace storey::cli
