// Bringup files: which components run in which process, with which parameters.
//
//   processes:
//     - name: robot1            # unique in the file
//       domain_id: 7            # optional; else ROS_DOMAIN_ID, else 0
//       components:
//         - kind: floor_detector    # a kind in the ComponentRegistry
//           name: detector1         # unique in the file
//           parameters: ../config/floor_detector.yaml   # optional; relative to this file
//
// A parameter file's top-level mapping is the component's parameters, read strictly.
#pragma once

#include <string>
#include <vector>

#include "storey/common/config.h"
#include "storey/runtime/component_registry.h"

namespace storey::runtime {

struct ComponentSpec {
  std::string kind;
  std::string name;
  std::string parameters_file;  // absolute or relative to the working directory; may be ""
};

struct ProcessSpec {
  std::string name;
  int domain_id = -1;  // -1: not given
  std::vector<ComponentSpec> components;
};

struct Bringup {
  std::string file;
  std::vector<ProcessSpec> processes;
  const ProcessSpec& process(const std::string& name) const;  // throws if absent
};

// Reads and checks a bringup file: keys, component kinds (against `registry`), unique
// names, and that every parameter file exists and is a YAML mapping. Throws
// common::ConfigError naming the file, key and line.
Bringup readBringup(const std::string& path, const ComponentRegistry& registry);

// The parameters of a component: its file, or an empty mapping when it has none.
common::ConfigNode loadParameters(const ComponentSpec& spec);

}  // namespace storey::runtime
