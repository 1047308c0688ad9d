"""Timing for the bench scripts: the best of a few runs."""
import time


def best(f, reps):
    """Run `f` `reps` times; return the shortest time in seconds and the last result."""
    times, out = [], None
    for _ in range(reps):
        t0 = time.perf_counter()
        out = f()
        times.append(time.perf_counter() - t0)
    return min(times), out
