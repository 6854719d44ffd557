"""Recording a session to MCAP, replaying it through a new session, and serving a recording like a
live lab (`lab replay --serve`)."""
