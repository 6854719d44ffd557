"""The realtime runtime: the 1 kHz loop, the Zenoh transport, the `lab serve` processes, the router,
access control, the command intake and the control lock, robot switches built beside the loop, the
LQR gain designer's worker process."""
