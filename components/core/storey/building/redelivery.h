// Recognises records the graph server accepted before and gets again: a restarted server
// receives the topics' whole transient-local history, and a restarted mapper re-sends its
// updates. Applying an old floor-graph update again would put back its older poses and
// journal it a second time; a constraint that was later retracted would come back.
#pragma once

#include <cstdint>
#include <map>
#include <set>
#include <vector>

#include "storey/building/journal.h"

namespace storey::building {

class RedeliveryFilter {
 public:
  // Notes a record the server accepts (and journals), with `building` as it stands
  // before the record is applied; records resumed from the journal are noted the same way.
  void noteAccepted(const BuildingGraph& building, const JournalRecord& record);

  // True for a record accepted before and delivered again:
  // - a floor-graph update whose sequence number is no later than the last accepted for
  //   its graph, and all of whose nodes (same stamps) and edges the graph already holds
  //   (an update with something new is not a re-delivery, whatever its number);
  // - a constraint identical to one accepted and since retracted.
  // Constraints on a node pair the graph holds, and retractions of what it does not hold,
  // are recognised by the server itself.
  bool isRedelivery(const BuildingGraph& building, const JournalRecord& record) const;

 private:
  std::map<int, std::uint32_t> last_sequence_;     // per floor graph
  std::set<std::vector<std::uint8_t>> retracted_;  // encoded constraints since retracted
};

}  // namespace storey::building
