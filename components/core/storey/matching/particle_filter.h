// The particle filter is in the localization module (storey/localization/particle_filter.h).
// This header keeps the old include path and names for code not yet moved to them; include
// the localization header and use storey::localization instead. Removed once nothing
// includes it (cmake/CheckIncludeOrder.cmake lists who still does).
#pragma once

#include "storey/localization/particle_filter.h"

namespace storey::matching {

using localization::FilterState;
using localization::LocalizationMap;
using localization::makeWallModel;
using localization::MotionNoiseOptions;
using localization::ParticleFilter;
using localization::ParticleFilterOptions;
using localization::readParticleFilterOptions;
using localization::selectBeams;
using localization::WallModel;

}  // namespace storey::matching
