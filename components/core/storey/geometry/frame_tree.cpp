#include "storey/geometry/frame_tree.h"

#include <stdexcept>

namespace storey::geometry {

void FrameTree::set(const std::string& parent, const std::string& child,
                    const Pose2& child_in_parent) {
  if (parent.empty() || child.empty()) {
    throw std::invalid_argument("transform '" + parent + "' -> '" + child +
                                "': a frame name is empty");
  }
  if (parent == child) throw std::invalid_argument("transform '" + parent + "' -> itself");
  for (auto it = parents_.find(parent); it != parents_.end();
       it = parents_.find(it->second.first)) {
    if (it->second.first == child) {
      throw std::invalid_argument("transform '" + parent + "' -> '" + child +
                                  "' closes a cycle of frames");
    }
  }
  parents_[child] = {parent, child_in_parent};
}

std::optional<Pose2> FrameTree::poseInFirstOf(const std::string& frame,
                                              const std::vector<std::string>& bases) const {
  // The chain from `frame` up to its root, each frame with its pose in that frame; set()
  // keeps the chain free of cycles.
  std::map<std::string, Pose2> chain{{frame, Pose2()}};
  Pose2 pose;
  for (auto it = parents_.find(frame); it != parents_.end(); it = parents_.find(it->second.first)) {
    pose = it->second.second * pose;
    chain.emplace(it->second.first, pose);
  }
  for (const std::string& base : bases) {
    if (const auto found = chain.find(base); found != chain.end()) return found->second;
  }
  return std::nullopt;
}

}  // namespace storey::geometry
