"""Bounding-volume hierarchies (the paper's section 4.1): build, serialize, traverse two at a time.

A tree is flat arrays (children by index, leaves by -1 children), built top
down over triangles; its nodes carry k-DOPs, of which the top ``aabb_levels``
levels use only the AABB slabs (the paper's hybrid), the rest all k/2.
"""
