"""Collision effects: the vehicle against the scene's obstacles (and, later, gun against drums)."""
