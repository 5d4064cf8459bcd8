"""Run one function over many points: on this machine's cores or on a Dask cluster.

Each point gets its own ``numpy.random.SeedSequence``, spawned from one seed, so a
result depends only on its point and its place in the list, never on where or in
which order it ran. Local runs use worker processes started with "spawn" (Drake's
threads do not survive a fork).
"""

from __future__ import annotations

import concurrent.futures
import multiprocessing
import os
from collections.abc import Callable, Sequence

import numpy as np


class PointFailed(RuntimeError):
    """A point's function raised; ``index`` and ``point`` name it, ``__cause__`` is the error."""

    def __init__(self, label: str, index: int, point, error: BaseException):
        super().__init__(f"{label}: point {index} ({point!r}) failed: {type(error).__name__}: {error}")
        self.index, self.point = index, point


def point_seeds(seed: int, count: int) -> list[np.random.SeedSequence]:
    """One independent SeedSequence per point, spawned from ``seed``."""
    return np.random.SeedSequence(seed).spawn(count)


def run_points(function: Callable, points: Sequence, seed: int, dask_address: str | None = None,
               workers: int | None = None, label: str = "points",
               progress: Callable[[int], None] | None = None) -> list:
    """[function(point, seed_sequence) for each point], in point order.

    ``function`` must be picklable (a module-level function, or a functools.partial of
    one). Runs on the Dask scheduler at ``dask_address`` (e.g. "tcp://host:8786") when
    given; else in ``workers`` local processes (default: the machine's cores), or in
    this process when ``workers`` is 1. ``progress(done)`` is called as points finish.
    Raises PointFailed naming the first point found failing."""
    points = list(points)
    if workers is not None and workers < 1:
        raise ValueError(f"workers must be >= 1; got {workers}")
    seeds = point_seeds(seed, len(points))
    if dask_address:
        return _run_on_dask(function, points, seeds, dask_address, label, progress)
    workers = min(workers or os.cpu_count() or 1, max(len(points), 1))
    if workers == 1:
        results = []
        for index, (point, point_seed) in enumerate(zip(points, seeds, strict=True)):
            try:
                results.append(function(point, point_seed))
            except Exception as error:
                raise PointFailed(label, index, point, error) from error
            if progress:
                progress(index + 1)
        return results
    return _run_in_processes(function, points, seeds, workers, label, progress)


def _run_in_processes(function, points, seeds, workers, label, progress) -> list:
    results = [None] * len(points)
    context = multiprocessing.get_context("spawn")
    with concurrent.futures.ProcessPoolExecutor(max_workers=workers, mp_context=context) as pool:
        futures = {pool.submit(function, point, point_seed): index
                   for index, (point, point_seed) in enumerate(zip(points, seeds, strict=True))}
        for done, future in enumerate(concurrent.futures.as_completed(futures), start=1):
            index = futures[future]
            try:
                results[index] = future.result()
            except Exception as error:
                for pending in futures:
                    pending.cancel()
                raise PointFailed(label, index, points[index], error) from error
            if progress:
                progress(done)
    return results


def _run_on_dask(function, points, seeds, address, label, progress) -> list:
    from distributed import Client, as_completed

    try:
        client = Client(address, timeout="3s")
    except OSError as error:
        raise ValueError(f"cannot reach the Dask scheduler at {address!r} ({error}); start one with "
                         "`dask scheduler` and workers with `dask worker ADDRESS`, or leave --dask out") from None
    try:
        futures = client.map(function, points, seeds, pure=False)
        index_of = {future.key: index for index, future in enumerate(futures)}
        results = [None] * len(points)
        for done, future in enumerate(as_completed(futures), start=1):
            index = index_of[future.key]
            try:
                results[index] = future.result()
            except Exception as error:
                client.cancel(futures)
                raise PointFailed(label, index, points[index], error) from error
            if progress:
                progress(done)
        return results
    finally:
        client.close()
