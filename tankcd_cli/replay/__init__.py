"""Replay: trajectories through the matchers and the effects the scene calls for, streamed in
chunks (``pipeline``, ``run``), fleets of them (``fleet``), the demo, and the replay map's data."""
