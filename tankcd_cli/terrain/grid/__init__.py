"""The grid layout: a DEM held as a raster of posts, never as vertices and faces. DEM sources
read by window, the tile-by-tile classification (locally, or on a Dask cluster), the store's
grid layout read through a tile cache, and the surface that answers every query by
arithmetic on posts."""
