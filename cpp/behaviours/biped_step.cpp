#include "behaviours/biped_step.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <pinocchio/math/rpy.hpp>
#include <stdexcept>

#include "behaviours/pipm.hpp"
#include "behaviours/swing.hpp"

namespace lab {
namespace {
constexpr double kYawLeadMax = 0.2;                 // rad, biped_step.py YAW_LEAD_MAX
constexpr double kRateLimits[3] = {0.3, 0.3, 2.0};  // m/s², m/s², rad/s²: RATE_LIMITS
constexpr double kPlanTolerance = 1e-4;             // m, PLAN_TOLERANCE

/// The angle in [-π, π].
double wrap(double angle) { return std::atan2(std::sin(angle), std::cos(angle)); }

/// The yaw of pinocchio's roll-pitch-yaw (pin.rpy.matrixToRpy(R)[2]).
double yaw_of(const Eigen::Map<const RowMatrix3>& R) {
  const Eigen::Matrix3d rotation = R;
  return pinocchio::rpy::matrixToRpy(rotation)(2);
}

bool in_transition(StepPhase phase) {
  return phase == StepPhase::kLiftTransition || phase == StepPhase::kLandTransition;
}
}  // namespace

// BipedStepping.update: advance Fig. 8a's state machine and set the references.
void BipedStepping::update(double t_now, const BipedModel& robot, const double* commanded,
                           const bool* touching, BipedReferences& refs) {
  if (!started) {
    since = t = t_now;
    started = true;
  }
  for (int k = 0; k < 3; ++k) {  // each value moved towards its target by at most its step
    const double step = (t_now - t) * kRateLimits[k];
    command(k) += std::min(std::max(commanded[k] - command(k), -step), step);
  }
  const double measured = yaw_of(robot.base_rotation);
  const double lead = wrap(yaw + command(2) * (t_now - t) - measured);
  yaw = measured + std::min(std::max(lead, -kYawLeadMax), kYawLeadMax);
  t = t_now;
  int s = swing;
  double elapsed = t_now - since;
  if (phase == StepPhase::kDual && elapsed >= times.dual) {
    enter(StepPhase::kLiftTransition, t_now);
  } else if (phase == StepPhase::kLiftTransition && elapsed >= times.transition) {
    liftoff = robot.contact_positions.row(s).transpose();
    swing_start = swing_t0 = t_now;
    swing_u0 = 0.0;
    swing_duration = times.lift + times.land;
    enter(StepPhase::kLift, t_now);
    target = plan_footstep(robot, t_now);
  } else if (phase == StepPhase::kLift && swing_done(t_now) >= lift_fraction()) {
    enter(StepPhase::kLand, t_now);
  } else if (phase == StepPhase::kLand && touching[s] &&
             swing_done(t_now) >= (times.lift + 0.5 * times.land) / (times.lift + times.land)) {
    ++steps;
    enter(StepPhase::kLandTransition, t_now);
  } else if (phase == StepPhase::kLandTransition && elapsed >= times.transition) {
    swing = 1 - s;
    enter(StepPhase::kDual, t_now);
  }
  elapsed = t_now - since;
  s = swing;
  const int stance = 1 - s;

  const bool in_air = phase == StepPhase::kLift || phase == StepPhase::kLand;
  refs.contact_active[0] = refs.contact_active[1] = true;
  refs.contact_active[s] = !in_air;
  refs.force_weight.setConstant(std::numeric_limits<double>::quiet_NaN());
  if (phase == StepPhase::kLiftTransition) {
    refs.force_weight(s) = std::max(0.0, 1.0 - elapsed / times.transition);  // eqs. 9-10
  } else if (phase == StepPhase::kLandTransition) {
    refs.force_weight(s) = std::min(1.0, elapsed / times.transition);
  }
  refs.swing_tracked[0] = refs.swing_tracked[1] = false;
  refs.swing_tracked[s] = phase != StepPhase::kDual;
  if (in_transition(phase)) {  // held where it stands
    refs.foot_velocity.row(s).setZero();
    refs.foot_acceleration.row(s).setZero();
    if (elapsed == 0.0) refs.foot_position.row(s) = robot.contact_positions.row(s);
  }
  if (elapsed == 0.0)  // the posture (lowest priority) holds the joints where they are
    refs.posture = robot.q.tail(refs.posture.size());
  if (in_air) {
    double done = swing_done(t_now);
    if (phase == StepPhase::kLift && done >= times.replan_from * lift_fraction()) {
      target = plan_footstep(robot, t_now);
      done = swing_done(t_now);
    }
    refs.foot_position = robot.contact_positions;
    refs.foot_velocity.setZero();
    refs.foot_acceleration.setZero();
    const Eigen::Matrix3d path =
        swing_reference(liftoff, target, times.step_height, done * swing_duration, swing_duration);
    refs.foot_position.row(s) = path.row(0);
    refs.foot_velocity.row(s) = path.row(1);
    refs.foot_acceleration.row(s) = path.row(2);
  }
  const auto& feet = robot.contact_positions;
  const double on_ground = in_air ? feet(stance, 2) : (feet(0, 2) + feet(1, 2)) / 2.0;
  refs.base_height = on_ground + height;
  const double c = std::cos(yaw), sn = std::sin(yaw);
  refs.base_rotation << c, -sn, 0.0, sn, c, 0.0, 0.0, 0.0, 1.0;
  refs.base_angular_velocity << 0.0, 0.0, command(2);
  refs.com = robot.com;  // the CoM moves as the pendulum: only reported, not tracked
  refs.com(2) = on_ground + com_height;
}

void BipedStepping::enter(StepPhase next, double t_now) {
  phase = next;
  since = t_now;
}

double BipedStepping::lift_fraction() const { return times.lift / (times.lift + times.land); }

// BipedStepping._swing_done: the fraction of the swing done at `t_now`.
double BipedStepping::swing_done(double t_now) const {
  return swing_u0 + (t_now - swing_t0) / swing_duration;
}

// BipedStepping._retime: end the swing `switch_in` s after `t_now` instead.
void BipedStepping::retime(double t_now, double switch_in) {
  const double done = swing_done(t_now);
  if (swing_u0 == 0.0) {
    const bool longer = switch_in > (1.0 - done) * swing_duration;
    lengthened += longer;
    shortened += !longer;
  }
  swing_u0 = done;
  swing_t0 = t_now;
  swing_duration = switch_in / (1.0 - done);
}

// BipedStepping._plan: the footstep (world x, y) from the CoM state and the stance foot.
Eigen::Vector2d BipedStepping::plan_footstep(const BipedModel& robot, double t_now) {
  const double switch_in = (1.0 - swing_done(t_now)) * swing_duration;
  const double shortest =
      std::min(switch_in, std::max(0.0, times.min_swing - (t_now - swing_start)));
  const double longest = std::max(switch_in, times.max_swing - (t_now - swing_start));
  const Eigen::Vector3d stance = robot.contact_positions.row(1 - swing).transpose();
  const double heading_yaw = yaw_of(robot.base_rotation);
  const double c = std::cos(heading_yaw), sn = std::sin(heading_yaw);
  Eigen::Matrix2d heading;  // heading frame (the body's yaw) → world
  heading << c, -sn, sn, c;
  const Eigen::Vector2d com = heading.transpose() * (robot.com.head<2>() - stance.head<2>());
  const Eigen::Vector2d velocity = heading.transpose() * robot.com_velocity.head<2>();
  const LinearSurface surface{std::max(robot.com(2) - stance(2), 0.05), 0.0, 0.0};
  const double side = sides(swing);

  const auto foot = [&](int axis, double switch_time) {
    const PipmState now{0.0, com(axis), velocity(axis)};
    return plan_step(now, 0.0, switch_time, times.reversal_time, surface,
                     axis == 0 ? times.impact_velocity_change : 0.0,
                     times.reach + std::abs(com(axis)), command(axis), kPlanTolerance)
        .foot;
  };
  const PipmState lateral{0.0, com(1), velocity(1)};
  double capped = lateral_switch_time(lateral, 0.0, switch_in, surface, times.max_lateral_speed,
                                      times.min_lateral_speed, shortest, longest);
  double y = foot(1, capped) + side * times.lateral_offset;
  if (side * y < times.min_width && capped > shortest) {  // a crossover: step at once
    capped = shortest;
    y = foot(1, capped) + side * times.lateral_offset;
  }
  if (std::abs(capped - switch_in) > 1e-9) retime(t_now, capped);
  Eigen::Vector2d step(foot(0, capped), y);
  step(0) = std::min(std::max(step(0), -times.reach), times.reach);
  step(1) = side * std::min(std::max(side * step(1), times.min_width), times.max_width);
  ++plans;
  const Eigen::Vector2d origin = heading.transpose() * stance.head<2>();
  plan = {t_now,   com(0),  com(1),         velocity(0), velocity(1), capped,
          step(0), step(1), surface.height, origin(0),   origin(1)};
  return stance.head<2>() + heading * step;
}

void BipedSteppingBehaviour::update(double t, const BehaviourModel& robot,
                                    const Eigen::Vector3d& command,
                                    const Eigen::Array<bool, Eigen::Dynamic, 1>& touching,
                                    References& refs) {
  if (robot.contact_positions.rows() != 2 || touching.size() != 2 ||
      refs.contact_active.size() != 2 || refs.swing_tracked.size() != 2 ||
      refs.force_weight.size() != 2 || refs.foot_position.size() != 6 ||
      refs.foot_velocity.size() != 6 || refs.foot_acceleration.size() != 6 ||
      refs.posture.size() != robot.v.size() - 6)
    throw std::invalid_argument(
        "native biped_step: two point feet need two contact flags, swing flags and force "
        "weights, 2 x 3 foot references and na posture references");
  const BipedModel model{robot.q, robot.base_rotation, robot.contact_positions, robot.com,
                         robot.com_velocity};
  RowMatrix3 rotation = refs.base_rotation;
  BipedReferences out{refs.contact_active.data(),
                      refs.swing_tracked.data(),
                      Eigen::Map<Eigen::Vector2d>(refs.force_weight.data()),
                      Eigen::Map<RowMatrixX3>(refs.foot_position.data(), 2, 3),
                      Eigen::Map<RowMatrixX3>(refs.foot_velocity.data(), 2, 3),
                      Eigen::Map<RowMatrixX3>(refs.foot_acceleration.data(), 2, 3),
                      Eigen::Map<Eigen::VectorXd>(refs.posture.data(), refs.posture.size()),
                      Eigen::Map<RowMatrix3>(rotation.data()),
                      Eigen::Map<Eigen::Vector3d>(refs.base_angular_velocity.data()),
                      Eigen::Map<Eigen::Vector3d>(refs.com.data()),
                      refs.base_height};
  stepping.update(t, model, command.data(), touching.data(), out);
  refs.base_rotation = rotation;
  refs.base_height = out.base_height;
}

}  // namespace lab
