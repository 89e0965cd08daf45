// Static planar transforms between named frames, as tf_static gives them (each child has
// one parent), and the pose of a frame in one of its ancestors along the chain.
#pragma once

#include <map>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "storey/geometry/pose2.h"

namespace storey::geometry {

class FrameTree {
 public:
  // Sets child's pose in parent, replacing child's earlier parent. Throws
  // std::invalid_argument naming the frames for an empty name, a frame its own parent, or
  // a transform that would close a cycle.
  void set(const std::string& parent, const std::string& child, const Pose2& child_in_parent);
  bool empty() const { return parents_.empty(); }

  // The pose of `frame` in the first of `bases` (in their order) that is `frame` itself or
  // one of its ancestors, composed along the chain; nullopt when none is.
  std::optional<Pose2> poseInFirstOf(const std::string& frame,
                                     const std::vector<std::string>& bases) const;

 private:
  std::map<std::string, std::pair<std::string, Pose2>> parents_;  // child -> (parent, pose)
};

}  // namespace storey::geometry
