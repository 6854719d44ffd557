"""The base state estimator (issue 30 item 1, docs/realism.md "The state estimator").

An extended Kalman filter on the IMU (accelerometer and gyroscope) and the leg kinematics of the
feet in contact, after Bloesch et al. 2013 ("State Estimation for Legged Robots: Consistent
Fusion of Leg Kinematics and IMU", RSS 2012), in the error-state form of Solà 2017
("Quaternion kinematics for the error-state Kalman filter", arXiv:1711.02508) with a local
angular error, and Hartley et al. 2020's contact augmentation at touchdown (IJRR, "Contact-aided
invariant extended Kalman filtering for robot state estimation", §VI). One concept per module:
state (the nominal state and its error's layout), process (the IMU's propagation), measurement
(the leg kinematics), filter (the EKF and its tuning). Pure: numpy and pinocchio, no threads,
I/O, MuJoCo or Zenoh. None of the three papers is in /work/shared/papers: the equations are
written out beside the code.
"""
