"""The timer the benchmarks share."""

import time


def best_of(fn, repeats):
    """The best wall-clock and the best CPU time over `repeats` calls."""
    wall, cpu = [], []
    for _ in range(repeats):
        t, c = time.perf_counter(), time.process_time()
        fn()
        wall.append(time.perf_counter() - t)
        cpu.append(time.process_time() - c)
    return min(wall), min(cpu)
