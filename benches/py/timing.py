"""What the Python benchmarks share: the best of several timed runs."""

import time


def best(f, runs=3):
    """The shortest of `runs` timings of `f()`, in seconds."""
    ts = []
    for _ in range(runs):
        t = time.perf_counter()
        f()
        ts.append(time.perf_counter() - t)
    return min(ts)
