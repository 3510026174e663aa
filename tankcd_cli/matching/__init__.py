"""Terrain matching: place the vehicle on the terrain (the paper's section 2.3).

``match`` is the entry point; ``pose`` holds the rotation conventions,
``keypoint`` the two-, four- and six-point matchers, ``reference`` the
rigid-hull ground truth they are measured against.
"""
