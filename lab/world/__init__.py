"""The simulated world a session runs: the MuJoCo plant, the session (its tick and commands), the
telemetry it publishes, its warning capture and memory trimming."""
