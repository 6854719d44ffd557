// Internal forces between point contacts (lab/controller/internal_force.py, Kim 2016 eqs. 14–17).
#include "internal_force.hpp"

namespace lab {

// internal_forces: W_int's row x̂ᵀ (λ_b − λ_a) per pair, applied without forming W_int.
void internal_forces(const std::vector<Eigen::Vector3d>& positions,
                     const std::vector<std::size_t>& feet,
                     const Eigen::Ref<const Eigen::VectorXd>& forces, Eigen::VectorXd& out) {
  const auto n = static_cast<Eigen::Index>(feet.size());
  out.resize(n * (n - 1) / 2);
  Eigen::Index row = 0;
  for (Eigen::Index a = 0; a < n; ++a)
    for (Eigen::Index b = a + 1; b < n; ++b, ++row) {
      const Eigen::Vector3d line = positions[feet[b]] - positions[feet[a]];
      const Eigen::Vector3d x_hat = line / line.norm();  // R_t's first row (eq. 16)
      // λ = −F, Δ_t = (I −I) (eq. 17)
      out[row] = x_hat.dot(-forces.segment<3>(3 * b)) - x_hat.dot(-forces.segment<3>(3 * a));
    }
}

}  // namespace lab
