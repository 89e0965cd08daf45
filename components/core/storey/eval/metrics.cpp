#include "storey/eval/metrics.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <sstream>
#include <stdexcept>

namespace storey::eval {
namespace {

constexpr double kPi = 3.14159265358979323846;

std::string fixed(double value, int digits) {
  char buffer[64];
  std::snprintf(buffer, sizeof(buffer), "%.*f", digits, value);
  return buffer;
}

std::string jsonString(const std::string& s) {
  std::string out = "\"";
  for (char c : s) {
    if (c == '"' || c == '\\') out += '\\';
    if (static_cast<unsigned char>(c) < 0x20) {
      char buffer[8];
      std::snprintf(buffer, sizeof(buffer), "\\u%04x", c);
      out += buffer;
      continue;
    }
    out += c;
  }
  return out + "\"";
}

std::string jsonNumber(double v) {
  if (!std::isfinite(v)) return "null";
  char buffer[64];
  std::snprintf(buffer, sizeof(buffer), "%.9g", v);
  return buffer;
}

void meanStd(const std::vector<double>& values, double* mean, double* std_dev) {
  *mean = *std_dev = 0.0;
  if (values.empty()) return;
  for (double v : values) *mean += v;
  *mean /= static_cast<double>(values.size());
  for (double v : values) *std_dev += (v - *mean) * (v - *mean);
  *std_dev = std::sqrt(*std_dev / static_cast<double>(values.size()));
}

}  // namespace

std::vector<PosePair> associate(const std::vector<PoseRow>& estimate,
                                const std::vector<PoseRow>& truth, double stamp_tolerance,
                                double max_gap, std::size_t* unmatched) {
  std::map<std::string, std::vector<const PoseRow*>> by_robot;
  for (const auto& row : estimate) by_robot[row.robot].push_back(&row);
  for (auto& [robot, rows] : by_robot)
    std::stable_sort(rows.begin(), rows.end(),
                     [](const PoseRow* a, const PoseRow* b) { return a->stamp < b->stamp; });
  std::vector<PosePair> pairs;
  std::size_t missing = 0;
  for (const auto& t : truth) {
    const auto it = by_robot.find(t.robot);
    if (it == by_robot.end()) {
      ++missing;
      continue;
    }
    const auto& rows = it->second;
    const auto upper = std::lower_bound(rows.begin(), rows.end(), t.stamp,
                                        [](const PoseRow* r, double s) { return r->stamp < s; });
    // Nearest neighbours on either side.
    const PoseRow* after = upper != rows.end() ? *upper : nullptr;
    const PoseRow* before = upper != rows.begin() ? *std::prev(upper) : nullptr;
    PosePair pair{t.robot, t.floor, t.stamp, {}, t.pose};
    if (after && std::abs(after->stamp - t.stamp) <= stamp_tolerance) {
      pair.estimate = after->pose;
    } else if (before && std::abs(before->stamp - t.stamp) <= stamp_tolerance) {
      pair.estimate = before->pose;
    } else if (before && after && after->stamp - before->stamp <= max_gap) {
      pair.estimate = geometry::interpolate(
          before->pose, after->pose, (t.stamp - before->stamp) / (after->stamp - before->stamp));
    } else {
      ++missing;
      continue;
    }
    pairs.push_back(pair);
  }
  if (unmatched) *unmatched = missing;
  return pairs;
}

geometry::Pose2 alignPoints(const std::vector<Eigen::Vector2d>& from,
                            const std::vector<Eigen::Vector2d>& to) {
  if (from.size() != to.size() || from.size() < 2)
    throw std::invalid_argument("alignPoints needs two or more corresponding points");
  Eigen::Vector2d mean_from = Eigen::Vector2d::Zero(), mean_to = Eigen::Vector2d::Zero();
  for (std::size_t i = 0; i < from.size(); ++i) {
    mean_from += from[i];
    mean_to += to[i];
  }
  mean_from /= static_cast<double>(from.size());
  mean_to /= static_cast<double>(to.size());
  // The rotation maximising sum of (R a_i) . b_i for centred points: atan2 of the summed
  // cross and dot products.
  double dot = 0.0, cross = 0.0;
  for (std::size_t i = 0; i < from.size(); ++i) {
    const Eigen::Vector2d a = from[i] - mean_from, b = to[i] - mean_to;
    dot += a.dot(b);
    cross += a.x() * b.y() - a.y() * b.x();
  }
  if (std::abs(dot) + std::abs(cross) < 1e-12)
    throw std::invalid_argument(
        "alignPoints: the points are all the same, the rotation is undefined");
  const double theta = std::atan2(cross, dot);
  const Eigen::Vector2d t = mean_to - geometry::Pose2(0.0, 0.0, theta).rotation() * mean_from;
  return geometry::Pose2(t.x(), t.y(), theta);
}

Evaluation evaluate(const std::vector<PoseRow>& estimate, const std::vector<PoseRow>& truth,
                    const std::vector<CorridorSpec>& corridors, const EvaluateOptions& options) {
  Evaluation result;
  std::vector<PosePair> pairs =
      associate(estimate, truth, options.stamp_tolerance, options.max_gap, &result.unmatched);
  result.matched = pairs.size();
  if (pairs.size() < 2)
    throw std::invalid_argument("fewer than two estimated poses match the ground truth stamps");

  std::vector<Eigen::Vector2d> from, to;
  for (const auto& p : pairs) {
    from.push_back(p.estimate.translation());
    to.push_back(p.truth.translation());
  }
  result.global_alignment = alignPoints(from, to);
  for (auto& p : pairs) p.estimate = result.global_alignment * p.estimate;

  double sum_sq = 0.0;
  for (const auto& p : pairs)
    sum_sq += (p.estimate.translation() - p.truth.translation()).squaredNorm();
  result.ate_rmse = std::sqrt(sum_sq / static_cast<double>(pairs.size()));

  // Per floor, in order of first appearance in the ground truth.
  std::vector<std::string> floor_order;
  for (const auto& t : truth)
    if (std::find(floor_order.begin(), floor_order.end(), t.floor) == floor_order.end())
      floor_order.push_back(t.floor);
  for (const auto& floor : floor_order) {
    FloorError error;
    error.floor = floor;
    std::vector<Eigen::Vector2d> a, b;
    double sq = 0.0;
    for (const auto& p : pairs) {
      if (p.floor != floor) continue;
      a.push_back(p.estimate.translation());
      b.push_back(p.truth.translation());
      const double d = (a.back() - b.back()).norm();
      sq += d * d;
      error.ate_mean += d;
      error.ate_max = std::max(error.ate_max, d);
    }
    error.poses = a.size();
    if (a.empty()) {
      result.floors.push_back(error);
      continue;
    }
    error.ate_rmse = std::sqrt(sq / static_cast<double>(a.size()));
    error.ate_mean /= static_cast<double>(a.size());
    if (a.size() >= 2) {
      try {
        error.residual = alignPoints(a, b);
      } catch (const std::invalid_argument&) {
        error.residual = geometry::Pose2();  // all at one spot: the rotation is unobservable
      }
      Eigen::Vector2d centroid = Eigen::Vector2d::Zero();
      for (const auto& p : a) centroid += p;
      centroid /= static_cast<double>(a.size());
      error.residual_translation = (error.residual.transformPoint(centroid) - centroid).norm();
      error.residual_rotation = std::abs(error.residual.theta());
    }
    result.floors.push_back(error);
  }

  // Relations between poses i and i + step of one robot, in stamp order.
  std::map<std::string, std::vector<const PosePair*>> by_robot;
  for (const auto& p : pairs) by_robot[p.robot].push_back(&p);
  for (auto& [robot, list] : by_robot)
    std::stable_sort(list.begin(), list.end(),
                     [](const PosePair* x, const PosePair* y) { return x->stamp < y->stamp; });
  for (int step : options.relation_steps) {
    RelationError relation;
    relation.step = step;
    std::vector<double> translation, rotation;
    for (const auto& [robot, list] : by_robot)
      for (std::size_t i = 0; i + step < list.size(); ++i) {
        const geometry::Pose2 true_delta = list[i]->truth.between(list[i + step]->truth);
        const geometry::Pose2 est_delta = list[i]->estimate.between(list[i + step]->estimate);
        const geometry::Pose2 error = true_delta.between(est_delta);
        translation.push_back(error.translation().norm());
        rotation.push_back(std::abs(error.theta()));
      }
    relation.count = translation.size();
    meanStd(translation, &relation.translation_mean, &relation.translation_std);
    meanStd(rotation, &relation.rotation_mean, &relation.rotation_std);
    result.relations.push_back(relation);
  }

  for (const auto& corridor : corridors) {
    CorridorError error;
    error.name = corridor.name;
    error.floor = corridor.floor;
    const PosePair* near_from = nullptr;
    const PosePair* near_to = nullptr;
    double best_from = options.corridor_max_distance, best_to = options.corridor_max_distance;
    for (const auto& p : pairs) {
      if (p.floor != corridor.floor) continue;
      const double df = (p.truth.translation() - corridor.from).norm();
      const double dt = (p.truth.translation() - corridor.to).norm();
      if (df <= best_from) best_from = df, near_from = &p;
      if (dt <= best_to) best_to = dt, near_to = &p;
    }
    if (near_from && near_to && near_from != near_to) {
      error.measured = true;
      error.stamp_from = near_from->stamp;
      error.stamp_to = near_to->stamp;
      error.true_length = (near_from->truth.translation() - near_to->truth.translation()).norm();
      error.estimated_length =
          (near_from->estimate.translation() - near_to->estimate.translation()).norm();
      error.ratio = error.true_length > 0.0 ? error.estimated_length / error.true_length : 0.0;
    }
    result.corridors.push_back(error);
  }
  return result;
}

std::string toJson(const Evaluation& e) {
  std::ostringstream out;
  out << "{\n  \"matched\": " << e.matched << ",\n  \"unmatched\": " << e.unmatched << ",\n";
  out << "  \"global_alignment\": {\"x\": " << jsonNumber(e.global_alignment.x())
      << ", \"y\": " << jsonNumber(e.global_alignment.y())
      << ", \"theta\": " << jsonNumber(e.global_alignment.theta()) << "},\n";
  out << "  \"ate_rmse\": " << jsonNumber(e.ate_rmse) << ",\n  \"floors\": [";
  for (std::size_t i = 0; i < e.floors.size(); ++i) {
    const FloorError& f = e.floors[i];
    out << (i ? ",\n" : "\n") << "    {\"floor\": " << jsonString(f.floor)
        << ", \"poses\": " << f.poses
        << ", \"alignment_translation\": " << jsonNumber(f.residual_translation)
        << ", \"alignment_rotation\": " << jsonNumber(f.residual_rotation)
        << ", \"alignment_rotation_deg\": " << jsonNumber(f.residual_rotation * 180.0 / kPi)
        << ", \"residual\": {\"x\": " << jsonNumber(f.residual.x())
        << ", \"y\": " << jsonNumber(f.residual.y())
        << ", \"theta\": " << jsonNumber(f.residual.theta())
        << "}, \"ate_rmse\": " << jsonNumber(f.ate_rmse)
        << ", \"ate_mean\": " << jsonNumber(f.ate_mean)
        << ", \"ate_max\": " << jsonNumber(f.ate_max) << "}";
  }
  out << "\n  ],\n  \"relations\": [";
  for (std::size_t i = 0; i < e.relations.size(); ++i) {
    const RelationError& r = e.relations[i];
    out << (i ? ",\n" : "\n") << "    {\"step\": " << r.step << ", \"count\": " << r.count
        << ", \"translation_mean\": " << jsonNumber(r.translation_mean)
        << ", \"translation_std\": " << jsonNumber(r.translation_std)
        << ", \"rotation_mean\": " << jsonNumber(r.rotation_mean)
        << ", \"rotation_std\": " << jsonNumber(r.rotation_std) << "}";
  }
  out << "\n  ],\n  \"corridors\": [";
  for (std::size_t i = 0; i < e.corridors.size(); ++i) {
    const CorridorError& c = e.corridors[i];
    out << (i ? ",\n" : "\n") << "    {\"name\": " << jsonString(c.name)
        << ", \"floor\": " << jsonString(c.floor)
        << ", \"measured\": " << (c.measured ? "true" : "false");
    if (c.measured)
      out << ", \"stamp_from\": " << jsonNumber(c.stamp_from)
          << ", \"stamp_to\": " << jsonNumber(c.stamp_to)
          << ", \"true_length\": " << jsonNumber(c.true_length)
          << ", \"estimated_length\": " << jsonNumber(c.estimated_length)
          << ", \"ratio\": " << jsonNumber(c.ratio);
    out << "}";
  }
  out << "\n  ]\n}\n";
  return out.str();
}

std::string toTable(const Evaluation& e) {
  std::ostringstream out;
  out << "poses matched " << e.matched << ", unmatched " << e.unmatched << "; global alignment ("
      << fixed(e.global_alignment.x(), 3) << " m, " << fixed(e.global_alignment.y(), 3) << " m, "
      << fixed(e.global_alignment.theta() * 180.0 / kPi, 3) << " deg); ATE RMSE "
      << fixed(e.ate_rmse, 3) << " m\n\n";
  out << "floor        poses   align.trans[m]  align.rot[deg]  ATE.rmse[m]  ATE.mean[m]  "
         "ATE.max[m]\n";
  for (const auto& f : e.floors) {
    char line[256];
    std::snprintf(line, sizeof(line), "%-12s %5zu %16.3f %15.3f %12.3f %12.3f %11.3f\n",
                  f.floor.c_str(), f.poses, f.residual_translation,
                  f.residual_rotation * 180.0 / kPi, f.ate_rmse, f.ate_mean, f.ate_max);
    out << line;
  }
  out << "\nrelations  count   trans.mean[m]  trans.std[m]  rot.mean[deg]  rot.std[deg]\n";
  for (const auto& r : e.relations) {
    char line[256];
    std::snprintf(line, sizeof(line), "step %-5d %5zu %15.4f %13.4f %14.4f %13.4f\n", r.step,
                  r.count, r.translation_mean, r.translation_std, r.rotation_mean * 180.0 / kPi,
                  r.rotation_std * 180.0 / kPi);
    out << line;
  }
  if (!e.corridors.empty()) {
    out << "\ncorridor             floor        true[m]   estimated[m]   ratio\n";
    for (const auto& c : e.corridors) {
      char line[256];
      if (c.measured)
        std::snprintf(line, sizeof(line), "%-20s %-12s %7.2f %14.2f %7.3f\n", c.name.c_str(),
                      c.floor.c_str(), c.true_length, c.estimated_length, c.ratio);
      else
        std::snprintf(line, sizeof(line),
                      "%-20s %-12s not measured (trajectory never near both ends)\n",
                      c.name.c_str(), c.floor.c_str());
      out << line;
    }
  }
  return out.str();
}

}  // namespace storey::eval
