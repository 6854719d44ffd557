// Static crawl of Hutter 2014 §5.1; mirrors lab/controller/behaviours/static_walk.py. Only its
// profiles are native so far (the crawl's tick runs in Python): body_motion.cpp uses min_jerk.
#pragma once

#include <Eigen/Dense>

namespace lab {

/// σ(s), σ'(s), σ''(s) of the minimum-jerk profile, s clamped to [0, 1] (static_walk.py).
Eigen::Vector3d min_jerk(double s);

}  // namespace lab
