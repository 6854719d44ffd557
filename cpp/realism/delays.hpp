// lab/realism/delays.py in C++: a delay of whole ticks as a ring buffer.
#pragma once

#include <Eigen/Core>

namespace lab::realism {

/// For each vector pushed, the one pushed `ticks` before (the first one until then).
class DelayLine {
 public:
  DelayLine(int ticks, int size) : ticks_(ticks), buffer_(Eigen::MatrixXd::Zero(size, ticks + 1)) {}
  void reset() {
    head_ = 0;
    filled_ = false;
  }
  /// Store `value`; return the value of `ticks` pushes ago.
  Eigen::VectorXd push(const Eigen::Ref<const Eigen::VectorXd>& value);

 private:
  int ticks_, head_ = 0;
  bool filled_ = false;
  Eigen::MatrixXd buffer_;  // one column per tick
};

}  // namespace lab::realism
