"""What reviewers open: a replay's poses and events as a page, GeoJSON, CZML, or a DIS capture
with Collision PDUs (docs/formats.md, "Outputs for review")."""
