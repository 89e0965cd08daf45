// The optimiser's options (read strictly from YAML) and its robust kernels.
#include <cmath>
#include <stdexcept>
#include <string>

#include "storey/graph/optimizer.h"

namespace storey::graph {

const char* robustKernelName(RobustKernelType type) {
  switch (type) {
    case RobustKernelType::kNone:
      return "none";
    case RobustKernelType::kHuber:
      return "huber";
    case RobustKernelType::kCauchy:
      return "cauchy";
    case RobustKernelType::kDcs:
      return "dcs";
  }
  return "unknown";
}

RobustKernelType parseRobustKernel(const std::string& name) {
  for (RobustKernelType t : {RobustKernelType::kNone, RobustKernelType::kHuber,
                             RobustKernelType::kCauchy, RobustKernelType::kDcs}) {
    if (name == robustKernelName(t)) return t;
  }
  throw std::invalid_argument("unknown robust kernel '" + name + "' (none, huber, cauchy, dcs)");
}

void robustKernel(const RobustKernel& kernel, double s, double* rho, double* weight) {
  const double d = kernel.delta;
  switch (kernel.type) {
    case RobustKernelType::kNone:
      *rho = s;
      *weight = 1.0;
      return;
    case RobustKernelType::kHuber:
      // Quadratic within δ, linear in √s beyond.
      if (s <= d * d) {
        *rho = s;
        *weight = 1.0;
      } else {
        const double r = std::sqrt(s);
        *rho = 2.0 * d * r - d * d;
        *weight = d / r;
      }
      return;
    case RobustKernelType::kCauchy: {
      const double d2 = d * d;
      *rho = d2 * std::log1p(s / d2);
      *weight = 1.0 / (1.0 + s / d2);
      return;
    }
    case RobustKernelType::kDcs:
      // Dynamic covariance scaling (Agarwal et al. 2013): the error is scaled by
      // σ = min(1, 2Φ / (Φ + s)), its information by σ². With the switch prior
      // Φ(1 − σ)² the cost σ²s + Φ(1 − σ)² equals Φ for every s ≥ Φ, so ρ = min(s, Φ).
      if (s <= d) {
        *rho = s;
        *weight = 1.0;
      } else {
        const double scale = 2.0 * d / (d + s);
        *weight = scale * scale;
        *rho = d;
      }
      return;
  }
  *rho = s;
  *weight = 1.0;
}

OptimizerOptions readOptimizerOptions(const common::ConfigNode& config, OptimizerOptions o) {
  const std::string algorithm = config.getChoice(
      "algorithm", o.algorithm == Algorithm::kGaussNewton ? "gn" : "lm", {"gn", "lm"});
  o.algorithm = algorithm == "gn" ? Algorithm::kGaussNewton : Algorithm::kLevenbergMarquardt;
  o.linear_solver = config.getChoice("linear_solver", o.linear_solver,
                                     {"cholmod", "cholmod_supernodal", "cholmod_nd", "eigen"});
  o.max_iterations = config.getInt("max_iterations", o.max_iterations, 1, 1000000);
  o.relative_chi2_tolerance =
      config.getDouble("relative_chi2_tolerance", o.relative_chi2_tolerance, 0.0, 1.0);
  o.step_tolerance = config.getDouble("step_tolerance", o.step_tolerance, 0.0, 1.0);
  o.initial_lambda = config.getDouble("initial_lambda", o.initial_lambda, 0.0, 1e10);
  o.restart_lambda = config.getDouble("restart_lambda", o.restart_lambda, 1e-20, 1e10);
  o.max_lambda = config.getDouble("max_lambda", o.max_lambda, 1e-10, 1e30);
  o.lambda_decrease_limit =
      config.getDouble("lambda_decrease_limit", o.lambda_decrease_limit, 1e-6, 1.0);
  o.chord_min_ratio = config.getDouble("chord_min_ratio", o.chord_min_ratio, 0.0, 1.0);
  o.chord_max_change = config.getDouble("chord_max_change", o.chord_max_change, 0.0, 1.0);
  o.chord_pcg_iterations = config.getInt("chord_pcg_iterations", o.chord_pcg_iterations, 0, 1000);
  o.chord_pcg_tolerance =
      config.getDouble("chord_pcg_tolerance", o.chord_pcg_tolerance, 1e-12, 1.0);
  o.chord_pcg_min_cost = config.getDouble("chord_pcg_min_cost", o.chord_pcg_min_cost, 0.0, 1e12);
  const std::string gauge =
      config.getChoice("gauge", o.gauge == GaugeMode::kFirstNode ? "first_node" : "per_component",
                       {"first_node", "per_component"});
  o.gauge = gauge == "first_node" ? GaugeMode::kFirstNode : GaugeMode::kPerComponent;
  const std::string init =
      config.getChoice("initialization",
                       o.initialization == Initialization::kNone               ? "none"
                       : o.initialization == Initialization::kOrientationFirst ? "orientation_first"
                                                                               : "auto",
                       {"none", "orientation_first", "auto"});
  o.initialization = init == "none"                ? Initialization::kNone
                     : init == "orientation_first" ? Initialization::kOrientationFirst
                                                   : Initialization::kAuto;
  o.auto_initialization_chi2 =
      config.getDouble("auto_initialization_chi2", o.auto_initialization_chi2, 0.0, 1e300);
  o.downweight_threshold =
      config.getDouble("downweight_threshold", o.downweight_threshold, 0.0, 1.0);
  o.verbose = config.get<bool>("verbose", o.verbose);
  if (config.has("robust")) {
    const common::ConfigNode robust = config.child("robust");
    for (const std::string& kind_name : robust.keys()) {
      EdgeKind kind;
      try {
        kind = parseEdgeKind(kind_name);
      } catch (const std::invalid_argument& error) {
        robust.fail(kind_name, error.what());
      }
      const common::ConfigNode entry = robust.child(kind_name);
      RobustKernel& kernel = o.robust[static_cast<int>(kind)];
      kernel.type =
          parseRobustKernel(entry.getChoice("kernel", {"none", "huber", "cauchy", "dcs"}));
      kernel.delta = entry.getDouble("delta", 1.0, 1e-12, 1e12);
      entry.finish();
    }
  }
  config.finish();
  return o;
}

}  // namespace storey::graph
