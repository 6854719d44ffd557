// lab/realism/delays.py in C++.
#include "realism/delays.hpp"

namespace lab::realism {

Eigen::VectorXd DelayLine::push(const Eigen::Ref<const Eigen::VectorXd>& value) {
  if (ticks_ == 0) return value;
  if (!filled_) buffer_.colwise() = value;  // at rest before the run
  filled_ = true;
  buffer_.col(head_) = value;
  head_ = (head_ + 1) % (ticks_ + 1);
  return buffer_.col(head_);  // the oldest: written `ticks` pushes ago
}

}  // namespace lab::realism
