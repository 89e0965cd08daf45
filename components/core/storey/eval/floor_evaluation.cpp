#include "storey/eval/floor_evaluation.h"

#include <cmath>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include "storey/common/config.h"
#include "storey/common/log.h"

namespace storey::eval {

using floor::FloorEvent;
using floor::FloorEventType;

using common::str;

namespace {

std::vector<std::string> splitCsv(const std::string& line) {
  std::vector<std::string> fields;
  std::stringstream in(line);
  std::string field;
  while (std::getline(in, field, ',')) fields.push_back(field);
  if (!line.empty() && line.back() == ',') fields.emplace_back();
  return fields;
}

double parseNumber(const std::string& text, const std::string& where) {
  std::size_t used = 0;
  double value = 0.0;
  try {
    value = std::stod(text, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used != text.size() || text.empty() || !std::isfinite(value)) {
    throw std::runtime_error(str(where, ": '", text, "' is not a number"));
  }
  return value;
}

}  // namespace

std::vector<TrueTransit> readTrueTransits(const std::string& dir) {
  // Floor heights first.
  const std::string floors_path = dir + "/floors.yaml";
  std::map<std::string, double> heights;
  {
    const common::ConfigNode root = common::ConfigNode::loadFile(floors_path);
    for (const auto& floor : root.sequence("floors")) {
      heights[floor.get<std::string>("id")] = floor.getDouble("height");
    }
  }
  const std::string path = dir + "/transits.csv";
  std::ifstream in(path);
  if (!in) throw std::runtime_error(str(path, ": cannot open"));
  std::vector<TrueTransit> transits;
  std::string line;
  int number = 0;
  // Columns by header name: later versions of the file may add columns.
  std::map<std::string, std::size_t> column;
  std::size_t width = 0;
  while (std::getline(in, line)) {
    ++number;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.empty()) continue;
    const std::string where = str(path, ":", number);
    const auto fields = splitCsv(line);
    if (column.empty()) {
      for (std::size_t i = 0; i < fields.size(); ++i) column[fields[i]] = i;
      for (const char* name : {"robot", "start", "end", "from_floor", "to_floor", "mode"}) {
        if (!column.count(name)) {
          throw std::runtime_error(str(where, ": header lacks the column '", name, "'"));
        }
      }
      width = fields.size();
      continue;
    }
    if (fields.size() != width) {
      throw std::runtime_error(
          str(where, ": expected ", width, " fields as in the header, found ", fields.size()));
    }
    TrueTransit t;
    t.robot = fields[column["robot"]];
    t.start = parseNumber(fields[column["start"]], where);
    t.end = parseNumber(fields[column["end"]], where);
    t.from_floor = fields[column["from_floor"]];
    t.to_floor = fields[column["to_floor"]];
    t.mode = fields[column["mode"]];
    for (const auto* id : {&t.from_floor, &t.to_floor}) {
      if (!heights.count(*id)) {
        throw std::runtime_error(str(where, ": floor '", *id, "' is not in ", floors_path));
      }
    }
    t.height_change = heights[t.to_floor] - heights[t.from_floor];
    transits.push_back(t);
  }
  return transits;
}

FloorComparison compareWithTruth(const std::vector<FloorEvent>& events,
                                 const std::vector<TrueTransit>& truth, double slack) {
  FloorComparison c;
  c.true_transits = static_cast<int>(truth.size());
  std::vector<const FloorEvent*> changes;
  for (const auto& e : events) {
    if (e.type == FloorEventType::kTransitEnded && e.floor_changed) changes.push_back(&e);
  }
  c.reported = static_cast<int>(changes.size());
  std::map<int, std::string> identity;  // detector floor id -> true floor id
  if (!truth.empty())
    identity[events.empty() ? 0 : events.front().from_floor] = truth.front().from_floor;
  std::vector<bool> used(changes.size(), false);
  double squared = 0.0;
  std::size_t next = 0;  // both lists are in time order
  for (const auto& t : truth) {
    int found = -1;
    for (std::size_t i = next; i < changes.size(); ++i) {
      const FloorEvent& e = *changes[i];
      if (e.start_stamp <= t.end + slack && e.stamp >= t.start - slack) {
        found = static_cast<int>(i);
        break;
      }
      if (e.start_stamp > t.end + slack) break;
    }
    if (found < 0) {
      ++c.missed;
      c.problems.push_back(str("missed: ", t.from_floor, " -> ", t.to_floor, " (", t.mode, ") at ",
                               t.start, "..", t.end, " s"));
      continue;
    }
    for (int i = static_cast<int>(next); i < found; ++i) {
      ++c.spurious;
      c.problems.push_back(str("spurious: floor ", changes[i]->from_floor, " -> ",
                               changes[i]->floor_id, " at ", changes[i]->start_stamp, "..",
                               changes[i]->stamp, " s"));
      used[i] = true;
    }
    used[found] = true;
    next = static_cast<std::size_t>(found) + 1;
    const FloorEvent& e = *changes[found];
    ++c.matched;
    const double error = e.height_change - t.height_change;
    squared += error * error;
    if (std::string(transitModeName(e.mode)) == t.mode) ++c.mode_correct;
    auto known = identity.find(e.floor_id);
    bool right = false;
    if (known != identity.end()) {
      right = known->second == t.to_floor;
    } else {
      // A floor the detector has not reached before must be a true floor it has not
      // reached before either (else it split one floor into two).
      right = true;
      for (const auto& [id, floor] : identity) right = right && floor != t.to_floor;
      identity[e.floor_id] = t.to_floor;
    }
    if (!right) {
      ++c.wrong_floor;
      c.problems.push_back(str("wrong floor: ", t.from_floor, " -> ", t.to_floor,
                               " reported as detector floor ", e.floor_id, " at ", t.start, " s"));
    }
  }
  for (std::size_t i = next; i < changes.size(); ++i) {
    ++c.spurious;
    c.problems.push_back(str("spurious: floor ", changes[i]->from_floor, " -> ",
                             changes[i]->floor_id, " at ", changes[i]->start_stamp, "..",
                             changes[i]->stamp, " s"));
  }
  c.height_rmse = c.matched > 0 ? std::sqrt(squared / c.matched) : 0.0;
  return c;
}

}  // namespace storey::eval
