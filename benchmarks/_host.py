"""
The host's speed at the moment of a benchmark: on a shared virtual machine the same code runs
up to half again slower from one minute to the next, invisibly to the load average (other
guests' work). A fixed pure-Python loop, timed before and after a benchmark, says how fast the
host was; compare runs only at like speeds.
"""

from __future__ import annotations

import time

__all__ = ["speed_probe"]


def speed_probe(repeat: int = 3) -> float:
    """The best of ``repeat`` timings [s] of ``sum(range(10**7))`` (about 0.17 s on a quiet
    host of the project's 2-core machine)."""
    best = float("inf")
    for _ in range(repeat):
        began = time.perf_counter()
        sum(range(10**7))
        best = min(best, time.perf_counter() - began)
    return best


def best(function, repeat: int = 5) -> float:
    """The shortest of ``repeat`` timings of ``function()`` [s] (a shared machine only ever
    adds time)."""
    import time

    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        function()
        times.append(time.perf_counter() - start)
    return min(times)
