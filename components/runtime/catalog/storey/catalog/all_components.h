// All of storey's component kinds, for `storey launch` and `storey component`.
#pragma once

#include "storey/runtime/component_registry.h"

namespace storey::catalog {

// Adds every storey component kind to `registry`. Each component library adds one line
// to all_components.cpp; its library is linked in automatically (components/runtime/
// CMakeLists.txt links every library in STOREY_LIBRARIES into storey_catalog).
void registerStoreyComponents(runtime::ComponentRegistry& registry);

}  // namespace storey::catalog
