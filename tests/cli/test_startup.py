"""A command imports only what its work needs: start-up is part of every command's cost."""

import subprocess
import sys

import numpy as np

from tests.conftest import write_asc

HEAVY = ("scipy", "matplotlib", "trimesh", "rasterio", "meshio", "numba", "llvmlite", "dask", "distributed",
         "pyarrow")

RUN = """
import sys
from tankcd_cli.cli.main import main
try:
    main(sys.argv[1:])
except SystemExit as exc:
    assert not exc.code, exc.code
print("LOADED=" + ",".join(m for m in {heavy!r} if m in sys.modules))
"""


def _loaded(*args):
    proc = subprocess.run([sys.executable, "-c", RUN.format(heavy=HEAVY), *map(str, args)], capture_output=True,
                          text=True)
    assert proc.returncode == 0, proc.stderr
    line = [x for x in proc.stdout.splitlines() if x.startswith("LOADED=")][-1]
    return {m for m in line[len("LOADED="):].split(",") if m}


def test_classify_of_an_esri_grid_and_a_short_replay_import_nothing_heavy(tmp_path):
    x = np.arange(40.0)
    src = write_asc(tmp_path / "g.asc", np.sin(x[:, None] / 7) * np.cos(x[None, :] / 5) + 100, xll=500000.0,
                    yll=4500000.0)
    assert _loaded("classify", src, "-o", tmp_path / "g.h5") == set()
    traj = tmp_path / "t.csv"
    traj.write_text("t,x,y,yaw_deg\n" + "".join(f"{i * 0.1},{500010 + i},{4500020},0\n" for i in range(10)))
    assert _loaded("replay", traj, "--terrain", tmp_path / "g.h5", "--poses", tmp_path / "p.csv") == set()
