"""Exact geometric primitives shared by the higher floors (no I/O, no state)."""
