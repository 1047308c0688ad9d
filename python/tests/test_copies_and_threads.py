"""The input is read in place (a contiguous float64 array is never copied; any other is copied once), and the GIL
is released while octavar computes, so other Python threads run meanwhile."""

import threading
import time
import tracemalloc

import numpy as np

import octavar

N = 1 << 21


def python_peak(f):
    """Peak of the Python-side allocations (numpy arrays included) while f runs, bytes."""
    tracemalloc.start()
    try:
        tracemalloc.reset_peak()
        f()
        return tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()


def test_a_float64_array_is_not_copied_and_another_is_copied_once():
    y = np.random.default_rng(1).standard_normal(N)
    size = y.nbytes
    for stat in ("adev", "oadev", "mdev", "hdev", "ohdev", "tdev", "totdev"):
        peak = python_peak(lambda: getattr(octavar, stat)(y, 100.0, "freq"))
        assert peak < 0.05 * size, (stat, peak, size)
    assert python_peak(lambda: octavar.deviation(y, 100.0)) < 0.05 * size
    assert python_peak(lambda: octavar.fit(y, 100.0)) < 0.05 * size
    # float32, integers and a strided view: one float64 copy, no more.
    for data in (y.astype(np.float32), (y * 100).astype(np.int32), np.repeat(y, 2)[::2]):
        peak = python_peak(lambda: octavar.oadev(data, 100.0, "freq"))
        assert 0.9 * size < peak < 1.1 * size, (data.dtype, peak, size)


def test_the_gil_is_released_while_octavar_computes():
    y = np.random.default_rng(2).standard_normal(1 << 22)
    done = threading.Event()
    spent = []

    def work():
        t0 = time.perf_counter()
        for _ in range(3):
            octavar.mdev(y, 100.0, "freq")
        spent.append(time.perf_counter() - t0)
        done.set()

    worker = threading.Thread(target=work)
    ticks = 0
    worker.start()
    t0 = time.perf_counter()
    while not done.is_set():
        ticks += 1
        time.sleep(0.001)
    worker.join()
    elapsed = time.perf_counter() - t0
    # With the GIL held by the computation, this thread would wake only at the end of each call (three times).
    assert spent[0] > 0.05, spent
    assert ticks > 20, (ticks, elapsed)
