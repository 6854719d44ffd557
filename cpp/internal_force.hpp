// Internal forces between point contacts (mirrors lab/controller/internal_force.py; Kim 2016 §IV,
// eqs. 14–17): for a pair of point feet a, b the tension along the line between them,
// F_int = x̂ᵀ (λ_b − λ_a), x̂ = (p_b − p_a)/‖p_b − p_a‖, λ = −F the force on the environment.
#pragma once

#include <Eigen/Dense>
#include <vector>

namespace lab {

/// F_int = W_int λ (eq. 41), one entry per pair a < b of the contacts `feet` (indices into
/// `positions`, world), from the forces on the robot `forces` (one 3-vector per entry of `feet`,
/// stacked); into `out`, resized to the number of pairs (internal_forces).
void internal_forces(const std::vector<Eigen::Vector3d>& positions,
                     const std::vector<std::size_t>& feet,
                     const Eigen::Ref<const Eigen::VectorXd>& forces, Eigen::VectorXd& out);

}  // namespace lab
