#include "storey/floor/floor_event.h"

namespace storey::floor {

const char* transitModeName(TransitMode mode) {
  switch (mode) {
    case TransitMode::kElevator:
      return "elevator";
    case TransitMode::kStairs:
      return "stairs";
    default:
      return "unknown";
  }
}

}  // namespace storey::floor
