"""Outputs for review (docs/formats.md, "Outputs for review"): a replay's poses and events read
back (``review``) and written as a page, GeoJSON, CZML or a DIS capture with Collision PDUs."""
