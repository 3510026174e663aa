"""Terrain matching: place the vehicle on the terrain (the paper's section 2.3).

``match.match`` is the entry point: the two-, four- and six-point and wheel-station matchers, the
rigid-hull reference they are measured against, ``AUTO_RULE`` (which one each
region class gets) and the certificate that escalates wrong key-point poses to
the reference. Rotations and poses are ``geometry.pose``; the exact ground under
the tracks is ``terrain.footprint``.
"""
