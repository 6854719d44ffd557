"""Sensors, delays, actuators and model error between the plant and the controller (issue 30).

One module per concept, each mirrored by cpp/realism/<module>.cpp where it runs per tick:
rng (the shared normal generator), sensors (IMU, encoders), delays (ring buffers), actuators
(torque bandwidth, SEA), layer (them together, the session's one call each side), knobs (the
typed configuration and presets), model_error (the controller's perturbed model). Pure: no
threads, I/O, MuJoCo or Zenoh (the presets' TOML is read by knobs.preset when asked).
"""
