#include "storey/sim/ground_truth.h"

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <tuple>

namespace storey::sim {
namespace {

std::ofstream openOut(const std::filesystem::path& path) {
  std::ofstream out(path);
  if (!out) throw std::runtime_error("cannot write " + path.string());
  return out;
}

std::string format(const char* pattern, double value) {
  char buffer[64];
  std::snprintf(buffer, sizeof(buffer), pattern, value);
  return buffer;
}

}  // namespace

void writeGroundTruth(const Simulation& simulation, const std::string& dir) {
  namespace fs = std::filesystem;
  fs::create_directories(dir);
  const Building& building = simulation.building;

  {
    // One time-ordered table over all robots (ties broken by robot order).
    struct Row {
      double stamp;
      std::size_t robot;
      const TruthSample* sample;
    };
    std::vector<Row> rows;
    for (std::size_t r = 0; r < simulation.robots.size(); ++r)
      for (const auto& s : simulation.robots[r].truth) rows.push_back({s.stamp, r, &s});
    std::stable_sort(rows.begin(), rows.end(), [](const Row& a, const Row& b) {
      return std::tie(a.stamp, a.robot) < std::tie(b.stamp, b.robot);
    });
    auto out = openOut(fs::path(dir) / "trajectory.csv");
    out << "stamp,robot,floor,x,y,theta,z\n";
    for (const auto& row : rows) {
      const TruthSample& s = *row.sample;
      out << format("%.6f", s.stamp) << ',' << simulation.robots[row.robot].name << ','
          << building.floors[s.floor].id << ',' << format("%.6f", s.pose.x()) << ','
          << format("%.6f", s.pose.y()) << ',' << format("%.9f", s.pose.theta()) << ','
          << format("%.6f", s.z) << '\n';
    }
    if (!out)
      throw std::runtime_error("cannot write " + (fs::path(dir) / "trajectory.csv").string());
  }
  {
    auto out = openOut(fs::path(dir) / "floors.yaml");
    out << "# True floors of simulated building " << building.name << " (seed " << simulation.seed
        << "). frame: the floor frame in the building frame,\n"
        << "# [x, y, theta] in metres and radians; height in metres.\n";
    out << "building: " << building.name << "\n";
    out << "scenario: " << simulation.scenario << "\n";
    out << "seed: " << simulation.seed << "\n";
    out << "pressure_drift_pa_per_s: " << format("%.9g", simulation.pressure_drift) << "\n";
    out << "floors:\n";
    for (const auto& floor : building.floors) {
      out << "  - id: " << floor.id << "\n";
      out << "    height: " << format("%.6f", floor.height) << "\n";
      out << "    frame: [" << format("%.6f", floor.frame.x()) << ", "
          << format("%.6f", floor.frame.y()) << ", " << format("%.9f", floor.frame.theta())
          << "]\n";
    }
  }
  {
    auto out = openOut(fs::path(dir) / "transits.csv");
    out << "robot,start,end,from_floor,to_floor,mode,odometry_heading_error\n";
    for (const auto& robot : simulation.robots)
      for (const auto& t : robot.transits)
        out << t.robot << ',' << format("%.6f", t.start) << ',' << format("%.6f", t.end) << ','
            << building.floors[t.from_floor].id << ',' << building.floors[t.to_floor].id << ','
            << t.mode << ',' << format("%.9f", t.odometry_heading_error) << '\n';
  }
  {
    auto out = openOut(fs::path(dir) / "corridors.yaml");
    out << "# Named straight distances, end points in the building frame.\n";
    out << "corridors:";
    if (building.corridors.empty()) out << " []";
    out << "\n";
    for (const auto& c : building.corridors) {
      const geometry::Pose2& frame = building.floor(c.floor).frame;
      const Eigen::Vector2d a = frame.transformPoint(c.from), b = frame.transformPoint(c.to);
      out << "  - {name: " << c.name << ", floor: " << c.floor << ", from: ["
          << format("%.6f", a.x()) << ", " << format("%.6f", a.y()) << "], to: ["
          << format("%.6f", b.x()) << ", " << format("%.6f", b.y()) << "]}\n";
    }
  }
}

void writeOdometryBaseline(const Simulation& simulation, const std::string& dir) {
  namespace fs = std::filesystem;
  fs::create_directories(dir);
  struct Row {
    double stamp;
    std::size_t robot;
    int floor;
    geometry::Pose2 pose;
    double z;
  };
  std::vector<Row> rows;
  for (std::size_t r = 0; r < simulation.robots.size(); ++r) {
    const RobotRun& robot = simulation.robots[r];
    if (robot.truth.empty() || robot.odometry.empty()) continue;
    const geometry::Pose2 start = robot.truth.front().pose;
    std::size_t k = 0;
    for (const auto& truth : robot.truth) {
      while (k + 1 < robot.odometry.size() && robot.odometry[k + 1].stamp <= truth.stamp) ++k;
      geometry::Pose2 odom = robot.odometry[k].pose;
      if (k + 1 < robot.odometry.size() && robot.odometry[k].stamp < truth.stamp) {
        const auto& a = robot.odometry[k];
        const auto& b = robot.odometry[k + 1];
        odom = geometry::interpolate(a.pose, b.pose, (truth.stamp - a.stamp) / (b.stamp - a.stamp));
      }
      rows.push_back({truth.stamp, r, truth.floor, start * odom, truth.z});
    }
  }
  std::stable_sort(rows.begin(), rows.end(), [](const Row& a, const Row& b) {
    return std::tie(a.stamp, a.robot) < std::tie(b.stamp, b.robot);
  });
  const fs::path path = fs::path(dir) / "trajectory.csv";
  auto out = openOut(path);
  out << "stamp,robot,floor,x,y,theta,z\n";
  for (const auto& row : rows)
    out << format("%.6f", row.stamp) << ',' << simulation.robots[row.robot].name << ','
        << simulation.building.floors[row.floor].id << ',' << format("%.6f", row.pose.x()) << ','
        << format("%.6f", row.pose.y()) << ',' << format("%.9f", row.pose.theta()) << ','
        << format("%.6f", row.z) << '\n';
  if (!out) throw std::runtime_error("cannot write " + path.string());
}

}  // namespace storey::sim
