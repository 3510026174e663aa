"""The mesh layout: an irregular terrain (TIN, scan, architecture, or a DEM read as a mesh) held
as vertices and faces: clean-up, edge topology, point location, the surface and its compiled
queries, the store's mesh layout and its classification."""
