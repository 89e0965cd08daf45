// The text report of a match: per floor and per pair, every candidate and its verdict.
#include <Eigen/Dense>
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <functional>
#include <iomanip>
#include <limits>
#include <map>
#include <mutex>
#include <numeric>
#include <ostream>
#include <random>
#include <set>
#include <sstream>
#include <thread>

#include "storey/common/log.h"
#include "storey/matching/floor_matcher.h"
#include "storey/matching/floor_matcher_internal.h"
#include "storey/matching/retraction.h"

namespace storey::matching {

using namespace detail;  // NOLINT(google-build-using-namespace): the stages' shared helpers

void printMatchReport(std::ostream& out, const MatchResult& result) {
  for (const auto& f : result.floors)
    out << "graph " << f.graph_id << ": structure " << f.structure << " cells, l_min " << f.l_min
        << ", own sequences at identity " << f.at_identity << ", elsewhere " << f.elsewhere
        << (f.fit_elsewhere >= 0.0
                ? common::str(" at (", f.other.x(), " m, ", f.other.y(), " m, ",
                              f.other.theta() * 180.0 / M_PI, " deg): whole-floor fit ",
                              f.fit_identity, " vs ", f.fit_elsewhere, "; at the identity, ",
                              f.refuted, " fit worse placed by it")
                : std::string())
        << (f.self_similar ? "  SELF-SIMILAR" : "") << "\n";
  out << "reference floor graph: " << result.reference_graph_id << "\n";
  for (const auto& p : result.pairs) {
    out << "graph " << p.graph_id << " in reference " << p.reference_graph_id << ": " << p.reason
        << " (" << p.sequences << " filters, " << p.not_converged << " not converged, "
        << p.wall_rechecks << " wall rechecks, l_min " << std::setprecision(4) << p.l_min << ", "
        << std::setprecision(3) << p.seconds << " s)\n";
    if (p.accepted) out << "  alignment (graph frame in reference frame): " << p.alignment << "\n";
    for (const auto& c : p.candidates) {
      out << "  " << (c.reversed ? "ref scans " : "scans ") << (c.backwards ? "<" : "")
          << c.first_index << ".." << c.last_index << " node " << c.node_id << " -> ref node "
          << c.reference_node_id << "  l_t " << std::setprecision(4) << c.likelihood << "  fit "
          << std::setprecision(3) << c.fit
          << (c.see_through >= 0.0 ? common::str("  through ", c.see_through) : std::string())
          << (c.information_ratio >= 0.0 ? common::str("  ratio ", c.information_ratio)
                                         : std::string())
          << "  particles " << c.particles << "  alignment " << c.alignment << "  c "
          << c.measurement << " dz " << c.dz << "  " << candidateStatusName(c.status);
      if (!c.reason.empty()) out << " (" << c.reason << ")";
      out << "\n";
    }
  }
  out << result.constraints.size() << " constraints accepted; " << result.beam_evaluations
      << " particle-beam evaluations in " << result.seconds << " s\n";
}

}  // namespace storey::matching
