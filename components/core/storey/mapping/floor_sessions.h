// One robot's floor graphs: the front end of the floor it is on, and the graphs of the
// floors it has left. A ride (floor event) pauses mapping; arriving on a new floor opens a
// new graph; arriving on a known floor (relocalization.known_floor: relocalize) buffers
// the arriving scans while localising them globally in that floor's map
// (GlobalRelocalizer) and then resumes its graph there. When global localisation does not
// give a checked estimate (or known_floor is new_graph) a new graph of that floor is
// opened for the floor matcher to align, and the buffered scans go into it: never a tie
// on a guess.
//
// An arrival the height alone does not decide (FloorEvent::candidate_floors) is decided
// here: the arriving scans are localised in every candidate floor's map at once. A floor
// that localises them, and whose points no other candidate's map fits as well, is the
// floor reached; when none is, a floor never seen if the height allows one and no
// candidate's map fits the latest scans anywhere, else the detector's choice (in a new
// graph). Floors alike where the robot arrived (a lift lobby) localise it in several
// candidates: then it is localised again, from the scans that follow, until one candidate
// alone holds them or the detector needs the answer. A floor never seen that looks like a
// known one where the robot drives is taken for that one: only the height tells them apart.
// First, though, when the floor left is a candidate: a scan that tracking on it would
// accept where odometry puts it says the robot never left (a gap in the heights while it
// drove on). The answer (takeIdentities) goes back to the detector.
#pragma once

#include <deque>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "storey/floor/floor_event.h"
#include "storey/mapping/floor_slam.h"
#include "storey/mapping/global_relocalizer.h"

namespace storey::mapping {

struct FloorSessionStats {
  std::size_t global_relocalizations = 0;  // known floors resumed after global localisation
  std::size_t fallbacks = 0;               // known floors given a new graph instead
  std::size_t unsure_arrivals = 0;         // arrivals with candidate floors
  std::size_t identified_by_map = 0;       // ... decided by localising in a candidate's map
};

class FloorSessions {
 public:
  // Graph ids are first_graph_id, +1, ... (unique across a fleet: see the floor_mapper
  // component's first_floor_graph_id).
  FloorSessions(FloorSlamOptions options, std::string robot, int initial_floor = 0,
                double initial_height = 0.0, int first_graph_id = 0);
  ~FloorSessions();

  // Passes the scan to the current floor's front end; while in transit, scans are held
  // (returned as kSkipped with the reason "in transit") until the ride's end is known;
  // while relocalising they are buffered (kSkipped, "relocalising") and added once it is
  // decided.
  ScanResult addScan(const sensor::LaserScan& scan, const geometry::Pose2& odometry);

  // A ride or stair climb started: stop mapping until it ends.
  void beginTransit();
  // It ended on `floor_id` at `end_stamp`. The same floor resumes as it was; another
  // floor is opened or resumed (after relocalisation). The detector decides an end some
  // seconds after it (the barometer must settle), when the robot has often left the
  // cabin: when the floor reached starts a new graph, the held scans stamped after
  // `end_stamp` start it; otherwise they are dropped.
  void endTransit(int floor_id, double floor_height, double end_stamp);
  // The same from the detector's event; an unsure arrival (candidate_floors) is decided by
  // localising the arriving scans in the candidates' maps (see the header comment).
  void endTransit(const floor::FloorEvent& event);
  // The detector waits for the floor of an unsure arrival (kAwaitingIdentity): decide now,
  // from the scans seen so far.
  void decideIdentity();
  bool identifying() const { return identify_ != nullptr; }
  // Decisions on unsure arrivals since the last call, for the detector.
  std::vector<floor::FloorIdentity> takeIdentities();
  // End of input: a relocalisation still undecided gets one last check of the filter's
  // estimate, else falls back to a new graph (so no scan is lost); the current floor is
  // finished (FloorSlam::finish: optimised, and successor matches made if they wait for it).
  void flush();

  bool inTransit() const { return in_transit_; }
  bool relocalizing() const { return relocalizer_ != nullptr; }
  const GlobalRelocalizer* relocalizer() const { return relocalizer_.get(); }
  int currentFloor() const { return current_floor_; }
  FloorSlam& current() { return *floors_.at(current_floor_); }
  const FloorSlam& current() const { return *floors_.at(current_floor_); }
  // The graph each floor is mapped into now (one per floor id).
  const std::map<int, std::unique_ptr<FloorSlam>>& floors() const { return floors_; }
  // Earlier graphs of floors visited again and not relocalised in (new_graph).
  const std::vector<std::unique_ptr<FloorSlam>>& retired() const { return retired_; }
  const FloorSessionStats& stats() const { return stats_; }
  // The result of the last global relocalisation attempt (accepted or not).
  const RelocalizationResult& lastRelocalization() const { return last_relocalization_; }

 private:
  void openNewGraphOfCurrentFloor(const std::string& why);
  void switchFloorAfterTransit(int floor_id, double floor_height);
  int resumeRelocalized();  // the relocaliser succeeded: resume the floor's graph
  // A scan to buffer must be as valid as the front end requires (it never sees buffered
  // scans one by one); true (r filled, logged) when it is not.
  bool rejectedForBuffer(const sensor::LaserScan& scan, const geometry::Pose2& odometry,
                         double last_stamp, ScanResult& r) const;
  // A global relocaliser in floor `floor_id`'s map, seeded per arrival, floor and restart
  // (deterministic, but not the same stream twice).
  std::unique_ptr<GlobalRelocalizer> relocalizerFor(int floor_id, int restart = 0) const;
  ScanResult addIdentifyingScan(const sensor::LaserScan& scan, const geometry::Pose2& odometry);
  int uniqueCandidate();  // index of the one candidate floor the scans localise in, or -1
  ScanResult resolveIdentity(int winner);

  FloorSlamOptions options_;
  std::string robot_;
  std::map<int, std::unique_ptr<FloorSlam>> floors_;
  std::vector<std::unique_ptr<FloorSlam>> retired_;
  std::map<int, geometry::Pose2> exit_pose_;  // where the robot left each floor
  std::unique_ptr<GlobalRelocalizer> relocalizer_;
  RelocalizationResult last_relocalization_;
  FloorSessionStats stats_;
  int current_floor_ = 0;
  int next_graph_id_ = 0;
  int arrivals_ = 0;  // seeds differ per arrival
  bool in_transit_ = false;
  struct HeldScan {
    sensor::LaserScan scan;
    geometry::Pose2 odometry;
  };
  std::deque<HeldScan> transit_scans_;  // while in transit, the last kHeldTransitSeconds
  struct Identification {
    floor::FloorEvent event;
    std::vector<std::pair<int, std::unique_ptr<GlobalRelocalizer>>> relocalizers;
    std::vector<HeldScan> buffer;
    int restarts = 0;
    int left = 0;             // the floor the robot was on
    bool check_left = false;  // the first scan may show it is still there (continuesHere)
  };
  std::unique_ptr<Identification> identify_;
  std::vector<floor::FloorIdentity> identities_;
};

}  // namespace storey::mapping
