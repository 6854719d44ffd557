// StaticWalk.update (static_walk.py): Hutter 2014 §5.1's static crawl.
#include "behaviours/static_walk.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace lab {

Eigen::Vector3d min_jerk(double s) {
  s = std::clamp(s, 0.0, 1.0);
  const double s2 = s * s, s3 = s2 * s, s4 = s3 * s, s5 = s4 * s;
  return {10 * s3 - 15 * s4 + 6 * s5, 30 * s2 - 60 * s3 + 30 * s4, 60 * s - 180 * s2 + 120 * s3};
}

Eigen::Vector3d bump(double s) {
  s = std::clamp(s, 0.0, 1.0);
  const double r = 1 - s;
  return {64 * s * s * s * r * r * r, 192 * s * s * r * r * (1 - 2 * s),
          384 * s * r * ((1 - 2 * s) * (1 - 2 * s) - s * r)};
}

Eigen::Vector2d inside_triangle(const Eigen::Vector2d& point,
                                const Eigen::Matrix<double, 3, 2>& triangle, double margin) {
  const Eigen::Vector2d centre = triangle.colwise().mean().transpose();
  std::array<Eigen::Vector2d, 3> normals;  // unit inward normal n, offset c: n·p ≥ c inside
  std::array<double, 3> offsets{};
  bool inside = true;
  for (int k = 0; k < 3; ++k) {
    const Eigen::Vector2d a = triangle.row(k).transpose(),
                          b = triangle.row((k + 1) % 3).transpose();
    Eigen::Vector2d n(a.y() - b.y(), b.x() - a.x());
    n /= n.norm();
    if (n.dot(centre - a) < 0) n = -n;
    normals[k] = n;
    offsets[k] = n.dot(a) + margin;
    inside = inside && n.dot(point) >= offsets[k];
  }
  if (inside) return point;
  // Corners of the shrunk triangle, then the nearest point on its boundary.
  std::array<Eigen::Vector2d, 3> corners;
  for (int k = 0; k < 3; ++k) {
    const int previous = (k + 2) % 3;
    Eigen::Matrix2d N;
    N << normals[previous].transpose(), normals[k].transpose();
    corners[k] = N.partialPivLu().solve(Eigen::Vector2d(offsets[previous], offsets[k]));
  }
  Eigen::Vector2d best = point;
  double best_distance = std::numeric_limits<double>::infinity();
  for (int k = 0; k < 3; ++k) {
    const Eigen::Vector2d a = corners[k], edge = corners[(k + 1) % 3] - a;
    const double t = std::clamp((point - a).dot(edge) / edge.dot(edge), 0.0, 1.0);
    const Eigen::Vector2d candidate = a + t * edge;
    const double distance = (candidate - point).norm();
    if (distance < best_distance) {
      best = candidate;
      best_distance = distance;
    }
  }
  return best;
}

Eigen::Vector3d StaticWalk::normal(const Eigen::Vector3d& point) const {
  return surface ? surface->normal(point) : Eigen::Vector3d::UnitZ();
}

void StaticWalk::update(double t, const BehaviourModel& /*robot*/,
                        const Eigen::Vector3d& /*command*/,
                        const Eigen::Array<bool, Eigen::Dynamic, 1>& /*touching*/,
                        References& refs) {
  const StaticWalkParameters& p = parameters;
  const Eigen::Index n = feet.rows();
  if (n != 4 || refs.contact_active.size() != n || refs.force_weight.size() != n ||
      refs.foot_position.size() != 3 * n || refs.surface_normal.size() != 3 * n)
    throw std::invalid_argument("native static_walk: four feet, their references and normals");
  const double elapsed = clock.since(t);
  const double into = std::fmod(elapsed, p.step_time());  // Python's divmod, elapsed ≥ 0
  const auto now = static_cast<long>(std::round((elapsed - into) / p.step_time()));
  if (now != step) begin_step(now, refs);
  const int leg = order[static_cast<std::size_t>(step % 4)];
  const int previous = order[static_cast<std::size_t>(((step - 1) % 4 + 4) % 4)];
  refs.contact_active.setConstant(true);
  refs.force_weight.setConstant(std::numeric_limits<double>::quiet_NaN());
  if (into < p.shift_time) {
    const Eigen::Vector3d sigma = min_jerk(into / p.shift_time);
    const Eigen::Vector3d delta = com_target - com_start;
    refs.com = com_start + sigma(0) * delta;
    refs.com_velocity = sigma(1) * delta / p.shift_time;
    if (into > p.shift_time - p.transition)  // unload the leg before lift-off (§5.1.6)
      refs.force_weight(leg) = (p.shift_time - into) / p.transition;
    if (step > 0 && into < p.transition)  // load the one that landed
      refs.force_weight(previous) = into / p.transition;
  } else {
    refs.com = com_target;
    refs.com_velocity.setZero();
    refs.contact_active(leg) = false;
    swing(leg, (into - p.shift_time) / p.swing_time, refs);
  }
}

void StaticWalk::begin_step(long next, References& refs) {
  step = next;
  const int leg = order[static_cast<std::size_t>(step % 4)];
  lift_off.row(leg) = feet.row(leg);
  feet.row(leg) += parameters.step_length * heading.transpose();
  Eigen::Matrix<double, 3, 2> support;
  for (int i = 0, row = 0; i < feet.rows(); ++i)
    if (i != leg) support.row(row++) = feet.row(i).head<2>();
  com_start = refs.com;
  const Eigen::Vector2d target = inside_triangle(com_start.head<2>(), support, parameters.margin);
  com_target << target, com_start.z();
  refs.surface_normal.segment<3>(3 * leg) = normal(feet.row(leg).transpose());
}

void StaticWalk::swing(int leg, double s, References& refs) {
  const double T = parameters.swing_time;
  const Eigen::Vector3d a = lift_off.row(leg).transpose(), b = feet.row(leg).transpose();
  const Eigen::Vector3d m = min_jerk(s), h = bump(s);
  const Eigen::Vector3d up = parameters.step_height * normal(a);
  refs.foot_position.segment<3>(3 * leg) = a + m(0) * (b - a) + h(0) * up;
  refs.foot_velocity.segment<3>(3 * leg) = (m(1) * (b - a) + h(1) * up) / T;
  refs.foot_acceleration.segment<3>(3 * leg) = (m(2) * (b - a) + h(2) * up) / (T * T);
  if (s >= 1.0) {
    refs.foot_velocity.segment<3>(3 * leg).setZero();
    refs.foot_acceleration.segment<3>(3 * leg).setZero();
  }
}

}  // namespace lab
