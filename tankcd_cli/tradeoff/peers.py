"""The peer libraries the trade-off report times tankcd's obstacle trees against (python-fcl, coal):
optional, imported only when asked for, "not installed" where absent."""

from __future__ import annotations

import time

import numpy as np

PEERS = (("python-fcl", "fcl"), ("coal", "coal"))  # (name in the report, module)


def peer_versions() -> dict:
    """{peer name: its version, "installed" (no version said) or "not installed"}."""
    info = {}
    for peer, module in PEERS:
        try:
            mod = __import__(module)
            info[peer] = getattr(mod, "__version__", "installed")
        except ImportError:
            info[peer] = "not installed"
    return info


def peer_query(name: str, tank_tris: np.ndarray, world_tris: np.ndarray, R: np.ndarray, t: np.ndarray):
    """(run, build seconds): ``run()`` answers the boolean hits (N,) with a peer library ("python-fcl"
    or "coal"), pose by pose from Python (neither has a batch API); None when the peer is not installed."""
    try:
        mod = __import__("fcl" if name in ("python-fcl", "fcl") else "coal")
    except ImportError:
        return None
    start = time.perf_counter()

    def arrays(tris):
        v = tris.reshape(-1, 3).astype(np.float64)
        return v, np.arange(len(v)).reshape(-1, 3).astype(np.int32)

    va, fa = arrays(tank_tris)
    vb, fb = arrays(world_tris)
    if name in ("python-fcl", "fcl"):
        fcl = mod
        ma = fcl.BVHModel()
        ma.beginModel(len(va), len(fa))
        ma.addSubModel(va, fa)
        ma.endModel()
        mb = fcl.BVHModel()
        mb.beginModel(len(vb), len(fb))
        mb.addSubModel(vb, fb)
        mb.endModel()
        oa = fcl.CollisionObject(ma, fcl.Transform())
        ob = fcl.CollisionObject(mb, fcl.Transform())
        req = fcl.CollisionRequest()

        def one(i):
            oa.setTransform(fcl.Transform(R[i], t[i]))
            return fcl.collide(oa, ob, req, fcl.CollisionResult()) > 0
    else:
        coal = mod

        def model(v, f):
            m = coal.BVHModelOBBRSS()
            m.beginModel(len(f), len(v))
            m.addVertices(v)
            m.addTriangles(f)
            m.endModel()
            return m
        ma, mb = model(va, fa), model(vb, fb)
        req = coal.CollisionRequest()
        identity = coal.Transform3s()

        def one(i):
            res = coal.CollisionResult()
            return coal.collide(ma, coal.Transform3s(R[i], t[i]), mb, identity, req, res) > 0
    build = time.perf_counter() - start

    def run():
        return np.array([one(i) for i in range(len(R))], dtype=bool)
    return run, build
