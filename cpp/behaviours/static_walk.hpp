// Static crawl of Hutter 2014 §5.1: footfall LH, LF, RH, RF, the CoG always over the support;
// mirrors lab/controller/behaviours/static_walk.py (StaticWalk.update, _begin_step, _swing,
// min_jerk, bump, inside_triangle), whose docstring describes the phases and the force
// interpolation weights of §5.1.6.
#pragma once

#include <Eigen/Dense>
#include <array>
#include <optional>

#include "behaviours/behaviour.hpp"
#include "surfaces.hpp"

namespace lab {

/// σ(s), σ'(s), σ''(s) of the minimum-jerk profile, s clamped to [0, 1].
Eigen::Vector3d min_jerk(double s);

/// 64 s³(1 − s)³ (peak 1 at s = ½, flat at both ends) and its first two derivatives.
Eigen::Vector3d bump(double s);

/// The point of the triangle (rows: its corners, 2-D) shrunk by `margin` nearest to `point`.
Eigen::Vector2d inside_triangle(const Eigen::Vector2d& point,
                                const Eigen::Matrix<double, 3, 2>& triangle, double margin);

/// Timing and geometry of the crawl (static_walk.py StaticWalkParameters).
struct StaticWalkParameters {
  double shift_time = 0.8, swing_time = 0.6, step_length = 0.08, step_height = 0.08, margin = 0.05,
         transition = 0.25;
  double step_time() const { return shift_time + swing_time; }
};

/// StaticWalk's state between ticks (static_walk.py StaticWalk; the same names).
class StaticWalk : public NativeBehaviour {
 public:
  StaticWalkParameters parameters;
  std::optional<HalfCylinder> surface;  // none: flat ground (world z up)
  std::array<int, 4> order{};           // the footfall's contact indices
  Eigen::Vector3d heading = Eigen::Vector3d::UnitX();
  RowMatrixX3 feet, lift_off;  // n x 3: where each foot stands (or will land), lifted from
  Eigen::Vector3d com_start = Eigen::Vector3d::Zero(), com_target = Eigen::Vector3d::Zero();
  MotionClock clock;  // Python: `start`
  long step = -1;

  void update(double t, const BehaviourModel& robot, const Eigen::Vector3d& command,
              const Eigen::Array<bool, Eigen::Dynamic, 1>& touching, References& refs) override;

 private:
  Eigen::Vector3d normal(const Eigen::Vector3d& point) const;
  void begin_step(long next, References& refs);
  void swing(int leg, double s, References& refs);
};

}  // namespace lab
