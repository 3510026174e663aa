"""Replay: trajectories through the matchers (and, later, the scene's effects), streamed in chunks."""
