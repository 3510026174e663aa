"""tankcd: place a tank on real terrain and tell when it collides.

The package in layers, lowest first; a module imports its own layer and those
below it, never one above, never in a circle, and no other module's private names
(``tests/test_layers.py`` holds it):

1. foundation: ``errors``, ``names`` (shared names and codes), ``tolerances``, ``threads``
2. geometry: ``geometry/`` (rotations, k-DOPs, triangle tests, cylinders, the
   support-plane LP, the grid record ``PostGrid``), ``vehicle``, ``vehicle_mesh``
3. io: ``io/`` file readers (terrain inputs by format family) and atomic writers
4. world: ``scene`` (the scene schema and what it places where)
5. terrain: ``terrain/``: ``open`` (open or classify any terrain), the ``Surface``
   protocol, the footprint pass, classes; ``mesh/``, ``grid/`` (the two layouts) and
   ``curvature/``
6. matching and trees: ``matching/``, ``bvh/``
7. collision: ``collision/``
8. runs: ``replay/``, ``tradeoff/``, ``plots``, ``describe``, ``sample``
9. command line: ``cli/`` (thin: parse, call one function, report)
"""

import os as _os

__version__ = "0.1.0"

# The kernels' OpenMP threads sleep between parallel loops instead of spinning, unless the
# environment says otherwise (read once, when the OpenMP runtime loads with the first kernel):
# on cores busy with other work a spinning thread takes the core the Python thread needs
# between loops (measured: a replay 20 % faster in wall time, 25 % less CPU, on a shared 2-core machine)
_os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")
