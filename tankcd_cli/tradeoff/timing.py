"""The timing harness of the trade-off report: medians of repeated calls, two workloads timed in
turn (pair by pair ratios that hold when a shared machine's speed drifts), the words a ratio is
reported in, and the machine the figures were taken on."""

from __future__ import annotations

import os
import platform
import time
from dataclasses import dataclass
from typing import Callable

import numpy as np

from tankcd_cli import __version__
from tankcd_cli.threads import get_num_threads, openmp_enabled
from tankcd_cli.tradeoff.peers import peer_versions


def timed(fn: Callable[[], object], repeats: int) -> tuple[float, float, float]:
    """Median, fastest and slowest seconds of ``repeats`` calls after one warm-up call."""
    fn()
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        fn()
        times.append(time.perf_counter() - start)
    return float(np.median(times)), float(min(times)), float(max(times))


@dataclass(frozen=True)
class Paired:
    """Two workloads timed in turn (A B A B ...), each ``repeats`` times after one warm-up of each:
    their medians and spreads (s), and the ratio B / A pair by pair (median, lowest, highest), which
    holds when the machine's speed drifts between pairs."""

    a: tuple  # (median, fastest, slowest) seconds
    b: tuple
    ratio: float
    ratio_lo: float
    ratio_hi: float

    @property
    def decided(self) -> bool:
        """Whether every pair agrees which is faster (the spread does not straddle 1)."""
        return self.ratio_lo > 1.0 or self.ratio_hi < 1.0


def paired(fn_a: Callable[[], object], fn_b: Callable[[], object], repeats: int, warm_up: bool = True,
           min_seconds: float = 0.0) -> Paired:
    """``fn_a`` and ``fn_b`` timed alternately (see ``Paired``); ``warm_up=False`` where the caller
    has already run each once. With ``min_seconds``, each turn calls its function again until that
    long has passed and counts the mean call: a call of a few milliseconds is at the mercy of one
    preemption on a shared machine, a turn of 0.1 s much less so."""
    if warm_up:
        fn_a()
        fn_b()
    ta, tb = [], []
    for _ in range(repeats):
        for fn, times in ((fn_a, ta), (fn_b, tb)):
            calls = 0
            start = time.perf_counter()
            while True:
                fn()
                calls += 1
                elapsed = time.perf_counter() - start
                if elapsed >= min_seconds:
                    break
            times.append(elapsed / calls)
    ratios = np.array(tb) / np.array(ta)
    spread = lambda v: (float(np.median(v)), float(min(v)), float(max(v)))  # noqa: E731
    return Paired(spread(ta), spread(tb), float(np.median(ratios)), float(ratios.min()), float(ratios.max()))


WIDE_SPREAD = 1.5
"""A ratio whose pairs range over more than this factor (highest / lowest) is not a figure to read."""


def spread_flag(lo: float, hi: float) -> str:
    """The short form of ``spread_caveat``, for a table's cell ("" when the range supports the ratio)."""
    if not (np.isfinite(lo) and np.isfinite(hi)) or lo <= 0:
        return "no spread"
    if lo <= 1.0 <= hi:
        return "the range holds 1.0x: cannot tell which is faster"
    if hi / lo > WIDE_SPREAD:
        return f"the range spans a factor of {hi / lo:.1f}: too wide to read"
    return ""


def spread_caveat(lo: float, hi: float) -> str:
    """Why a ratio's range cannot support it ("" when it can): the pairs disagree which is faster
    (the range holds 1), or they range over more than ``WIDE_SPREAD``."""
    if not (np.isfinite(lo) and np.isfinite(hi)) or lo <= 0:
        return "no spread measured: the figure cannot be judged"
    if lo <= 1.0 <= hi:
        return "this machine's spread cannot tell which is faster"
    if hi / lo > WIDE_SPREAD:
        return (f"the pairs range over a factor of {hi / lo:.1f}, more than {WIDE_SPREAD:g}: this machine's "
                "spread cannot support the figure")
    return ""


def ratio_text(value: float, lo: float, hi: float, faster: str, slower: str, what: str = "") -> str:
    """A ratio as words a reader can trust: "3.1x faster (pairs 2.8-3.4x)", "1.6x slower", or, where
    the pairs disagree which is faster, that the spread cannot tell; where they range over more than
    a factor of ``WIDE_SPREAD``, the figure with that caveat beside it."""
    caveat = spread_caveat(lo, hi)
    if lo <= 1.0 <= hi:
        return f"within noise of {what or 'the other'} (pairs {lo:.2f}-{hi:.2f}x: {caveat})"
    note = f"; {caveat}" if caveat else ""
    if value >= 1.0:
        return f"{value:.1f}x {faster} (pairs {lo:.1f}-{hi:.1f}x{note})"
    return f"{1 / value:.1f}x {slower} (pairs {1 / hi:.1f}-{1 / lo:.1f}x{note})"


def cost_text(value: float, lo: float, hi: float, of: str) -> str:
    """What one workload costs against another: "1.9x the time of plain auto (pairs 1.7-2.1x)", or,
    where the pairs disagree which is faster, that the spread cannot tell; a range wider than a
    factor of ``WIDE_SPREAD`` is said beside the figure."""
    caveat = spread_caveat(lo, hi)
    if lo <= 1.0 <= hi:
        return f"within noise of {of} (pairs {lo:.2f}-{hi:.2f}x: {caveat})"
    note = f"; {caveat}" if caveat else ""
    return f"{value:.2f}x the time of {of} (pairs {lo:.2f}-{hi:.2f}x{note})"


def machine() -> dict:
    """CPU, cores and the versions that decide the figures (the peers' too: "not installed" where absent)."""
    import scipy

    cpu = platform.processor() or platform.machine()
    try:
        with open("/proc/cpuinfo") as fh:
            names = [line.split(":", 1)[1].strip() for line in fh if line.startswith("model name")]
        if names:
            cpu = names[0]
    except OSError:
        pass
    info = {"cpu": cpu, "cores": os.cpu_count(), "threads": get_num_threads() if openmp_enabled() else 1,
            "os": platform.platform(), "python": platform.python_version(), "numpy": np.__version__,
            "scipy": scipy.__version__, "tankcd": __version__}
    info.update(peer_versions())
    return info
