#include "storey/geometry/pose2.h"

#include <ostream>

namespace storey::geometry {

double normalizeAngle(double angle) {
  if (angle >= -M_PI && angle < M_PI) return angle;
  double wrapped = std::fmod(angle + M_PI, 2.0 * M_PI);
  if (wrapped < 0.0) wrapped += 2.0 * M_PI;
  wrapped -= M_PI;
  // fmod can land exactly on pi after rounding; keep the interval half-open.
  return wrapped >= M_PI ? wrapped - 2.0 * M_PI : wrapped;
}

Eigen::Matrix2d Pose2::rotation() const {
  const double c = std::cos(theta_), s = std::sin(theta_);
  Eigen::Matrix2d r;
  r << c, -s, s, c;
  return r;
}

Eigen::Matrix3d Pose2::matrix() const {
  Eigen::Matrix3d m = Eigen::Matrix3d::Identity();
  m.topLeftCorner<2, 2>() = rotation();
  m(0, 2) = x_;
  m(1, 2) = y_;
  return m;
}

Pose2 Pose2::operator*(const Pose2& o) const {
  const double c = std::cos(theta_), s = std::sin(theta_);
  return Pose2(x_ + c * o.x_ - s * o.y_, y_ + s * o.x_ + c * o.y_, theta_ + o.theta_);
}

Pose2 Pose2::inverse() const {
  const double c = std::cos(theta_), s = std::sin(theta_);
  return Pose2(-c * x_ - s * y_, s * x_ - c * y_, -theta_);
}

Eigen::Vector2d Pose2::transformPoint(const Eigen::Vector2d& p) const {
  const double c = std::cos(theta_), s = std::sin(theta_);
  return {x_ + c * p.x() - s * p.y(), y_ + s * p.x() + c * p.y()};
}

std::vector<Eigen::Vector2d> Pose2::transformPoints(const std::vector<Eigen::Vector2d>& points) const {
  std::vector<Eigen::Vector2d> out;
  transformPoints(points, &out);
  return out;
}

void Pose2::transformPoints(const std::vector<Eigen::Vector2d>& points, std::vector<Eigen::Vector2d>* out) const {
  const double c = std::cos(theta_), s = std::sin(theta_);
  out->resize(points.size());  // a no-op when out is points
  for (std::size_t i = 0; i < points.size(); ++i) {
    const Eigen::Vector2d p = points[i];
    (*out)[i] = Eigen::Vector2d(x_ + c * p.x() - s * p.y(), y_ + s * p.x() + c * p.y());
  }
}

Eigen::Vector2d Pose2::inverseTransformPoint(const Eigen::Vector2d& p) const {
  const double c = std::cos(theta_), s = std::sin(theta_);
  const double dx = p.x() - x_, dy = p.y() - y_;
  return {c * dx + s * dy, -s * dx + c * dy};
}

std::ostream& operator<<(std::ostream& out, const Pose2& pose) {
  return out << "(" << pose.x() << ", " << pose.y() << ", " << pose.theta() << ")";
}

Pose2 interpolate(const Pose2& a, const Pose2& b, double t) {
  return Pose2(a.x() + t * (b.x() - a.x()), a.y() + t * (b.y() - a.y()),
               a.theta() + t * angleDiff(b.theta(), a.theta()));
}

void composeJacobians(const Pose2& a, const Pose2& b, Eigen::Matrix3d* d_a, Eigen::Matrix3d* d_b) {
  const double c = std::cos(a.theta()), s = std::sin(a.theta());
  if (d_a) {
    *d_a << 1, 0, -s * b.x() - c * b.y(),  //
        0, 1, c * b.x() - s * b.y(),       //
        0, 0, 1;
  }
  if (d_b) {
    *d_b << c, -s, 0,  //
        s, c, 0,       //
        0, 0, 1;
  }
}

Eigen::Matrix3d inverseJacobian(const Pose2& a) {
  const double c = std::cos(a.theta()), s = std::sin(a.theta());
  Eigen::Matrix3d j;
  j << -c, -s, s * a.x() - c * a.y(),  //
      s, -c, c * a.x() + s * a.y(),    //
      0, 0, -1;
  return j;
}

Eigen::Matrix3d composeCovariance(const Pose2& a, const Eigen::Matrix3d& cov_a, const Pose2& b,
                                  const Eigen::Matrix3d& cov_b) {
  Eigen::Matrix3d ja, jb;
  composeJacobians(a, b, &ja, &jb);
  return ja * cov_a * ja.transpose() + jb * cov_b * jb.transpose();
}

}  // namespace storey::geometry
