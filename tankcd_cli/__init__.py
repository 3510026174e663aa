"""tankcd: place a tank on real terrain and tell when it collides.

The package is laid out by pipeline stage, every import pointing down:

- ``cli/``      one module per command (thin: parse, call one function, report)
- ``terrain/``  loading clean-up, mean curvature, region classes, the HDF5 store
- ``io/``       file readers and atomic writers
- ``vehicle``   vehicle presets (dimensions from public sources)
- ``errors``, ``tolerances``: the shared error type and the one tolerance table
"""

__version__ = "0.1.0"
