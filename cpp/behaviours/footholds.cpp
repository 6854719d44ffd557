#include "behaviours/footholds.hpp"

#include <cmath>

namespace lab {
namespace {
constexpr double kGravity = 9.81;     // footholds.py GRAVITY
constexpr double kRaibertGain = 1.0;  // k_fb of Hutter eq. 62

Eigen::Vector2d to_world(const FootholdQuery& query, double x, double y) {
  const double c = std::cos(query.yaw), s = std::sin(query.yaw);
  return {query.base_xy.x() + c * x - s * y, query.base_xy.y() + s * x + c * y};
}

/// The hip's commanded velocity v_d + ψ̇_d ẑ × x_hip.
Eigen::Vector2d desired(const FootholdQuery& query) {
  return {query.velocity.x() - query.yaw_rate * query.hip.y(),
          query.velocity.y() + query.yaw_rate * query.hip.x()};
}
}  // namespace

Eigen::Vector2d robocentric(const FootholdQuery& query) {
  // Raiola eqs. 19-23: x_f⁰ + ΔL_xy0 + ΔL_h0, over half the stance time (footholds.py).
  const Eigen::Vector2d v = desired(query);
  const double T = 0.5 * query.stance_time;
  return to_world(query, query.hip.x() + T * v.x(), query.hip.y() + T * v.y());
}

Eigen::Vector2d raibert(const FootholdQuery& query) {
  // Hutter eq. 62 about the hip's position at touchdown: the hip at touchdown, + the
  // feed-forward T_st / 2 v_d + the feedback k_fb (v_hip − v_d) √(h/g).
  const Eigen::Vector2d v = desired(query);
  const double ahead = query.swing_left, half_stance = 0.5 * query.stance_time;
  const double gain = kRaibertGain * std::sqrt(query.height / kGravity);
  return to_world(
      query,
      query.hip.x() + ahead * v.x() + half_stance * v.x() + gain * (query.hip_velocity.x() - v.x()),
      query.hip.y() + ahead * v.y() + half_stance * v.y() +
          gain * (query.hip_velocity.y() - v.y()));
}

Eigen::Vector2d plan_foothold(FootholdPlanner planner, const FootholdQuery& query) {
  return planner == FootholdPlanner::kRaibert ? raibert(query) : robocentric(query);
}

}  // namespace lab
