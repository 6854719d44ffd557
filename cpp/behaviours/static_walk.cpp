// The static crawl's profiles (static_walk.py min_jerk).
#include "behaviours/static_walk.hpp"

#include <algorithm>

namespace lab {

Eigen::Vector3d min_jerk(double s) {
  s = std::clamp(s, 0.0, 1.0);
  const double s2 = s * s, s3 = s2 * s, s4 = s3 * s, s5 = s4 * s;
  return {10 * s3 - 15 * s4 + 6 * s5, 30 * s2 - 60 * s3 + 30 * s4, 60 * s - 180 * s2 + 120 * s3};
}

}  // namespace lab
