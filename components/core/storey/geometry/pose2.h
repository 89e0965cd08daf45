// SE(2) rigid transforms. A Pose2 maps points from its own frame into its parent frame:
// p_parent = R(theta) * p_local + t. Composition a * b applies b first, then a.
#pragma once

#include <Eigen/Core>
#include <cmath>
#include <iosfwd>
#include <vector>

namespace storey::geometry {

// Wraps an angle into [-pi, pi).
double normalizeAngle(double angle);
// Smallest signed difference a - b, wrapped.
inline double angleDiff(double a, double b) { return normalizeAngle(a - b); }

class Pose2 {
 public:
  Pose2() = default;
  Pose2(double x, double y, double theta) : x_(x), y_(y), theta_(normalizeAngle(theta)) {}
  explicit Pose2(const Eigen::Vector3d& v) : Pose2(v.x(), v.y(), v.z()) {}

  double x() const { return x_; }
  double y() const { return y_; }
  double theta() const { return theta_; }
  Eigen::Vector2d translation() const { return {x_, y_}; }
  Eigen::Matrix2d rotation() const;
  Eigen::Vector3d vector() const { return {x_, y_, theta_}; }
  Eigen::Matrix3d matrix() const;  // homogeneous 3x3

  Pose2 operator*(const Pose2& other) const;
  Pose2 inverse() const;
  // this^-1 * other: other expressed in this pose's frame.
  Pose2 between(const Pose2& other) const { return inverse() * other; }
  Eigen::Vector2d transformPoint(const Eigen::Vector2d& p) const;
  // transformPoint of each, with one sine and cosine for all (the same results).
  std::vector<Eigen::Vector2d> transformPoints(const std::vector<Eigen::Vector2d>& points) const;
  // The same into `out` (resized; may be `points` itself), for callers reusing a buffer.
  void transformPoints(const std::vector<Eigen::Vector2d>& points, std::vector<Eigen::Vector2d>* out) const;
  Eigen::Vector2d inverseTransformPoint(const Eigen::Vector2d& p) const;

  bool isFinite() const { return std::isfinite(x_) && std::isfinite(y_) && std::isfinite(theta_); }

 private:
  double x_ = 0.0;
  double y_ = 0.0;
  double theta_ = 0.0;
};

std::ostream& operator<<(std::ostream& out, const Pose2& pose);

// Linear interpolation of translation and shortest-arc interpolation of heading; t in [0, 1].
Pose2 interpolate(const Pose2& a, const Pose2& b, double t);

// Jacobians of c = a * b with respect to a and b (in the (x, y, theta) parametrisation).
void composeJacobians(const Pose2& a, const Pose2& b, Eigen::Matrix3d* d_a, Eigen::Matrix3d* d_b);
// Jacobian of a^-1 with respect to a.
Eigen::Matrix3d inverseJacobian(const Pose2& a);
// Covariance of a * b given independent covariances of a and b (first-order propagation).
Eigen::Matrix3d composeCovariance(const Pose2& a, const Eigen::Matrix3d& cov_a, const Pose2& b,
                                  const Eigen::Matrix3d& cov_b);

// A pose in the building frame: a planar pose on a floor plus that floor's height.
struct BuildingPose {
  int floor = 0;
  double height = 0.0;  // metres above the building origin
  Pose2 pose;
};

}  // namespace storey::geometry
