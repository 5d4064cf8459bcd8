"""run_points: the same results in order, sequentially, in local processes and on Dask."""

import numpy as np
import pytest

from heft.analysis.parallel import PointFailed, point_seeds, run_points

POINTS = [{"n": n, "scale": 0.5 * n} for n in range(1, 7)]


def seeded_draws(point, seed_sequence):
    """A seeded random function: point-dependent draws from the point's own seed."""
    rng = np.random.default_rng(seed_sequence)
    return point["scale"] * rng.standard_normal(point["n"])


def fails_on_three(point, seed_sequence):
    if point["n"] == 3:
        raise ArithmeticError("three is not allowed")
    return point["n"]


def expected():
    """The draws computed here, point by point, from the documented seeding."""
    return [p["scale"] * np.random.default_rng(s).standard_normal(p["n"])
            for p, s in zip(POINTS, np.random.SeedSequence(11).spawn(len(POINTS)), strict=True)]


def assert_same(results, reference):
    assert len(results) == len(reference)
    for got, want in zip(results, reference, strict=True):
        np.testing.assert_array_equal(got, want)


def test_seeds_are_independent_and_reproducible():
    a, b = point_seeds(11, 4), point_seeds(11, 4)
    draws = [np.random.default_rng(s).integers(1 << 62) for s in a]
    assert draws == [np.random.default_rng(s).integers(1 << 62) for s in b]
    assert len(set(draws)) == 4


def test_sequential_and_two_local_processes_agree():
    progress = []
    sequential = run_points(seeded_draws, POINTS, seed=11, workers=1, progress=progress.append)
    assert progress == list(range(1, len(POINTS) + 1))
    assert_same(sequential, expected())
    assert_same(run_points(seeded_draws, POINTS, seed=11, workers=2), expected())
    different_seed = run_points(seeded_draws, POINTS, seed=12, workers=1)
    assert not np.array_equal(different_seed[-1], sequential[-1])


def test_dask_local_cluster_agrees():
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=False,
                                  dashboard_address=None) as cluster:
        done = []
        results = run_points(seeded_draws, POINTS, seed=11, dask_address=cluster.scheduler_address,
                             progress=done.append)
        assert_same(results, expected())
        assert sorted(done) == list(range(1, len(POINTS) + 1))
        with pytest.raises(PointFailed, match=r"point 2 \(\{'n': 3"):
            run_points(fails_on_three, POINTS, seed=0, dask_address=cluster.scheduler_address)


@pytest.mark.parametrize("workers", [1, 2])
def test_a_failing_point_is_named(workers):
    with pytest.raises(PointFailed, match=r"sweep: point 2 \(\{'n': 3, 'scale': 1.5\}\) failed: "
                                          r"ArithmeticError: three is not allowed") as caught:
        run_points(fails_on_three, POINTS, seed=0, workers=workers, label="sweep")
    assert caught.value.index == 2 and isinstance(caught.value.__cause__, ArithmeticError)


def test_bad_worker_count_and_unreachable_scheduler_are_value_errors():
    with pytest.raises(ValueError, match="workers must be >= 1"):
        run_points(seeded_draws, POINTS, seed=0, workers=0)
    with pytest.raises(ValueError, match="cannot reach the Dask scheduler"):
        run_points(seeded_draws, POINTS, seed=0, dask_address="tcp://127.0.0.1:9")
