"""Collision effects of a replay and of ``tankcd collide``: the vehicle against the scene's
obstacles (``obstacles``: trees built or read from the cache, broad phase, triangle queries),
the gun barrel against the rear fuel drums and the gun elevation envelope (``internal``), and
the hull's bottom against the terrain (``terrain_contact``)."""
