// Foothold planners: where a swinging foot should land, in world x, y, replanned every tick;
// mirrors lab/controller/behaviours/footholds.py (robocentric: Raiola eqs. 19-25; raibert:
// Hutter eq. 62), whose docstring explains both.
#pragma once

#include <Eigen/Core>

namespace lab {

/// What a planner needs for one swinging leg, every vector in H axes except `base_xy`
/// (footholds.py FootholdQuery).
struct FootholdQuery {
  Eigen::Vector2d base_xy;
  double yaw;
  Eigen::Vector2d hip;           // the virtual foothold x_f⁰ under the hip, relative to the base
  Eigen::Vector2d velocity;      // commanded base velocity [vx, vy]
  double yaw_rate;               // commanded turning rate
  Eigen::Vector2d hip_velocity;  // measured velocity of the hip point
  double height;                 // base height above the feet
  double swing_left;             // time until the planned touchdown
  double stance_time;
  double swing_time;
};

/// The planners of footholds.py FOOTHOLD_PLANNERS, by name.
enum class FootholdPlanner { kRobocentric, kRaibert };

Eigen::Vector2d robocentric(const FootholdQuery& query);
Eigen::Vector2d raibert(const FootholdQuery& query);
Eigen::Vector2d plan_foothold(FootholdPlanner planner, const FootholdQuery& query);

}  // namespace lab
