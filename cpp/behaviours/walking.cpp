#include "behaviours/walking.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "behaviours/swing.hpp"

namespace lab {
namespace {
constexpr double kAccelerationLimit = 1.0;     // m/s², walking.py ACCELERATION_LIMIT
constexpr double kYawAccelerationLimit = 2.0;  // rad/s², YAW_ACCELERATION_LIMIT
constexpr double kRateLimits[3] = {kAccelerationLimit, kAccelerationLimit, kYawAccelerationLimit};
constexpr double kYawLeadMax = 0.2;               // rad, YAW_LEAD_MAX
constexpr double kHipVelocityTimeConstant = 0.1;  // s, HIP_VELOCITY_TIME_CONSTANT
constexpr double kUnboundedLoads = 5.0;           // UNBOUNDED_LOADS

/// The angle in [-π, π].
double wrap(double angle) { return std::atan2(std::sin(angle), std::cos(angle)); }

double clamp(double x, double bound) { return std::min(std::max(x, -bound), bound); }
}  // namespace

void Walking::update(double t_now, const WalkingModel& robot, const double* target,
                     const bool* touching, WalkingReferences& refs, LegPostureState& posture) {
  const auto& R = robot.base_rotation;
  const double yaw = std::atan2(R(1, 0), R(0, 0));
  const double dt = t_now - t;
  t = t_now;
  for (int k = 0; k < 3; ++k)  // each value moved towards its target by at most its step
    command(k) = command(k) + clamp(target[k] - command(k), dt * kRateLimits[k]);
  const double vx = command(0), vy = command(1), yaw_rate = command(2);
  const double lead = wrap(yaw_ref + yaw_rate * dt - yaw);
  yaw_ref = yaw + clamp(lead, kYawLeadMax);
  const double c = std::cos(yaw), s = std::sin(yaw);

  // The gait from the measured contacts (Raiola §3.1); a leg's posture restarts from its
  // measured joints at lift-off and touchdown.
  const int n = static_cast<int>(scheduler.legs.size());
  scheduler.advance(t_now, touching, events);
  if (!events.empty()) {
    std::vector<int> standing;
    for (int i = 0; i < n; ++i) {
      const bool changed = std::any_of(events.begin(), events.end(),
                                       [i](const LegEvent& event) { return event.leg == i; });
      if (scheduler.legs[i].state == LegState::kStance && !changed) standing.push_back(i);
    }
    static const std::vector<int> kNone;
    const Eigen::Map<const Eigen::VectorXd> joint_positions(robot.q.data() + 7, robot.q.size() - 7);
    for (const LegEvent& event : events) {
      if (event.liftoff) liftoff.row(event.leg) = robot.contact_positions.row(event.leg);
      leg_posture_restart(robot.contact_jacobian, joint_positions, *posture.joints, event.leg,
                          event.liftoff ? kNone : standing, posture.damping, posture.position);
    }
  }
  filter_twist(robot, c, s, dt);

  bool stance[kMaxLegs] = {};
  bool all_stance = true;
  double on_ground = 0.0;
  int standing_count = 0;
  for (int i = 0; i < n; ++i) {
    stance[i] = scheduler.legs[i].state == LegState::kStance;
    refs.contact_active[i] = stance[i];
    all_stance = all_stance && stance[i];
  }
  for (int i = 0; i < n; ++i) {
    const double load = scheduler.load(i, t_now);  // 0 in the air
    refs.posture_weight(i) = load;                 // the leg's postural rows fade with its load
    if (stance[i])
      refs.normal_force_max(i) = load < 1.0 ? load * full_load : kUnboundedLoads * full_load;
  }
  for (int i = 0; i < n; ++i) {
    if (!stance[i]) continue;
    on_ground += robot.contact_positions(i, 2);
    ++standing_count;
  }
  // The trunk's height above the mean of the stance feet (Raiola eq. 17: blind, it follows the
  // ground).
  if (standing_count > 0) refs.base_height = on_ground / standing_count + height;
  if (!all_stance) swing_feet(t_now, robot, yaw, stance, refs);

  // Level with the commanded heading, at the commanded velocity (Hutter Table 7); the CoM moves
  // with the base.
  const double cr = std::cos(yaw_ref), sr = std::sin(yaw_ref);
  refs.base_rotation << cr, -sr, 0.0, sr, cr, 0.0, 0.0, 0.0, 1.0;
  refs.base_angular_velocity << 0.0, 0.0, yaw_rate;
  refs.base_linear_velocity << c * vx - s * vy, s * vx + c * vy, 0.0;
  const double x = robot.q(0), y = robot.q(1), z = robot.q(2);
  const double ox = com_offset(0), oy = com_offset(1), oz = com_offset(2);
  refs.com << x + c * ox - s * oy, y + s * ox + c * oy, refs.base_height + oz;
  refs.com_velocity = refs.base_linear_velocity;

  // LegPostureReference.update (leg_posture.cpp): q̇_d, then q_d integrated.
  const LegPostureInput in{robot.contact_positions,
                           robot.contact_rotations,
                           robot.contact_jacobian,
                           posture.radius,
                           refs.contact_active,
                           Eigen::Map<const RowMatrixX3>(refs.foot_position.data(), n, 3),
                           Eigen::Map<const RowMatrixX3>(refs.foot_velocity.data(), n, 3),
                           robot.q.head<3>(),
                           refs.base_linear_velocity,
                           refs.base_angular_velocity,
                           refs.base_height - z,  // ΔH_z, eq. 32
                           dt,
                           posture.damping};
  leg_posture_velocity(in, posture.previous_rotations, posture.velocity);
  posture.position += dt * posture.velocity;
}

void Walking::swing_feet(double t_now, const WalkingModel& robot, double yaw, const bool* stance,
                         WalkingReferences& refs) {
  const double swing_time = scheduler.swing_time();
  const Eigen::Vector2d base_xy = robot.q.head<2>();
  const double base_vx = measured_twist(0), base_vy = measured_twist(1);
  const double spin = measured_twist(2);
  for (std::size_t i = 0; i < scheduler.legs.size(); ++i) {
    if (stance[i]) continue;
    const Leg& leg = scheduler.legs[i];
    const double elapsed = t_now - leg.since;
    const double hip_x = hips[i].x(), hip_y = hips[i].y();
    FootholdQuery query;
    query.base_xy = base_xy;
    query.yaw = yaw;
    query.hip = hips[i];
    query.velocity = command.head<2>();
    query.yaw_rate = command(2);
    query.hip_velocity = {base_vx - spin * hip_y, base_vy + spin * hip_x};  // + ω_z ẑ × hip
    query.height = height;
    query.swing_left = std::max(leg.swing_duration - elapsed, 0.0);
    query.stance_time = cycle_time - swing_time;
    query.swing_time = swing_time;
    const Eigen::Matrix3d swing =
        swing_reference(liftoff.row(i).transpose(), plan_foothold(footholds, query), step_height,
                        elapsed, leg.swing_duration);
    refs.foot_position.row(i) = swing.row(0);
    refs.foot_velocity.row(i) = swing.row(1);
    refs.foot_acceleration.row(i) = swing.row(2);
  }
}

void Walking::filter_twist(const WalkingModel& robot, double c, double s, double dt) {
  // Low-pass of the measured base velocity (H axes) and yaw rate, for the Raibert feedback
  // (walking.py _filter_twist: filtering the base twist filters every hip's velocity).
  const double alpha = dt / (kHipVelocityTimeConstant + dt);
  const Eigen::Vector3d velocity = robot.base_rotation * robot.v.head<3>();
  const double spin = robot.base_rotation.row(2).dot(robot.v.segment<3>(3));
  const double vx = velocity(0), vy = velocity(1);
  const double fx = measured_twist(0), fy = measured_twist(1), fs = measured_twist(2);
  measured_twist << fx + alpha * (c * vx + s * vy - fx), fy + alpha * (c * vy - s * vx - fy),
      fs + alpha * (spin - fs);
}

void WalkingBehaviour::update(double t, const BehaviourModel& robot, const Eigen::Vector3d& command,
                              const Eigen::Array<bool, Eigen::Dynamic, 1>& touching,
                              References& refs) {
  const Eigen::Index n = robot.contact_positions.rows(), nv = robot.v.size();
  if (robot.contact_jacobian.rows() != 3 * n || touching.size() != n ||
      refs.contact_active.size() != n || refs.posture_weight.size() != n ||
      refs.normal_force_max.size() != n || refs.foot_position.size() != 3 * n ||
      refs.foot_velocity.size() != 3 * n || refs.foot_acceleration.size() != 3 * n ||
      refs.posture.size() != nv - 6 || refs.posture_velocity.size() != nv - 6 ||
      previous_rotations.rows() != 3 * n || radius.size() != n ||
      walking.scheduler.legs.size() != static_cast<std::size_t>(n))
    throw std::invalid_argument(
        "native walking: n point feet need n contact flags, weights, force bounds, radii and "
        "legs, n x 3 foot references and na posture references");
  const WalkingModel model{robot.q,
                           robot.v,
                           robot.base_rotation,
                           robot.contact_positions,
                           robot.contact_rotations,
                           robot.contact_jacobian};
  RowMatrix3 rotation = refs.base_rotation;
  WalkingReferences out{refs.contact_active.data(),
                        Eigen::Map<Eigen::VectorXd>(refs.posture_weight.data(), n),
                        Eigen::Map<Eigen::VectorXd>(refs.normal_force_max.data(), n),
                        Eigen::Map<RowMatrixX3>(refs.foot_position.data(), n, 3),
                        Eigen::Map<RowMatrixX3>(refs.foot_velocity.data(), n, 3),
                        Eigen::Map<RowMatrixX3>(refs.foot_acceleration.data(), n, 3),
                        Eigen::Map<RowMatrix3>(rotation.data()),
                        Eigen::Map<Eigen::Vector3d>(refs.base_angular_velocity.data()),
                        Eigen::Map<Eigen::Vector3d>(refs.base_linear_velocity.data()),
                        Eigen::Map<Eigen::Vector3d>(refs.com.data()),
                        Eigen::Map<Eigen::Vector3d>(refs.com_velocity.data()),
                        refs.base_height};
  LegPostureState posture{Eigen::Map<Eigen::VectorXd>(refs.posture.data(), nv - 6),
                          Eigen::Map<Eigen::VectorXd>(refs.posture_velocity.data(), nv - 6),
                          Eigen::Map<RowMatrixX3>(previous_rotations.data(), 3 * n, 3),
                          Eigen::Map<const Eigen::VectorXd>(radius.data(), n),
                          &joints,
                          damping};
  walking.update(t, model, command.data(), touching.data(), out, posture);
  refs.base_rotation = rotation;
  refs.base_height = out.base_height;
}

}  // namespace lab
