// Known terrain geometry the behaviours may use (mirrors lab/controller/surfaces.py).
#pragma once

#include <Eigen/Dense>

namespace lab {

/// A cylinder with its axis along world x at height `axis_height` (y = 0), Hutter 2014 §5.1.5's
/// half cylinder (surfaces.py HalfCylinder).
struct HalfCylinder {
  double radius = 0.0;
  double axis_height = 0.0;

  /// Outward unit normal of the surface nearest `point` (world).
  Eigen::Vector3d normal(const Eigen::Vector3d& point) const {
    return Eigen::Vector3d(0.0, point.y(), point.z() - axis_height).normalized();
  }
};

}  // namespace lab
