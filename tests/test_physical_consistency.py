"""Physical consistency of φ: the pseudo-inertia against a point-mass cloud summed directly, the
projection against the physical set's own test and against nearby physical candidates."""

import numpy as np

from heft.systems.load_dynamics import InertialParameters, pseudo_inertia
from heft.systems.identification.physical_consistency import phi_from_pseudo_inertia, project_to_physical


def test_pseudo_inertia_equals_the_point_mass_sum():
    """J = Σ mᵢ [rᵢ; 1][rᵢ; 1]ᵀ for a cloud of point masses, whose φ is summed directly."""
    rng = np.random.default_rng(22)
    masses, points = rng.uniform(0.1, 1.0, 20), rng.normal(scale=0.1, size=(20, 3))
    inertia = sum(m * (p @ p * np.eye(3) - np.outer(p, p)) for m, p in zip(masses, points))
    phi = np.concatenate(([masses.sum()], masses @ points, inertia[np.triu_indices(3)]))
    homogeneous = np.column_stack((points, np.ones(20)))
    expected = (homogeneous * masses[:, None]).T @ homogeneous
    np.testing.assert_allclose(pseudo_inertia(phi), expected, atol=1e-14)
    np.testing.assert_allclose(phi_from_pseudo_inertia(expected), phi, atol=1e-14)


def test_projection_leaves_physical_loads_unchanged_and_repairs_others():
    rng = np.random.default_rng(23)
    for _ in range(100):
        phi = InertialParameters.random(rng).to_phi()
        np.testing.assert_allclose(project_to_physical(phi), phi, rtol=0, atol=1e-12)
        broken = phi + rng.normal(size=10) * np.r_[1.0, [0.1] * 3, [0.02] * 6]
        repaired = project_to_physical(broken)
        assert InertialParameters.from_phi(repaired).violations() == []
    # a massless, inside-out "body": all of J's eigenvalues negative
    repaired = project_to_physical(-np.array([1.0, 0, 0, 0, 1, 0, 0, 1, 0, 1]))
    assert InertialParameters.from_phi(repaired).violations() == []


def test_projection_is_nearest_in_the_scaled_pseudo_inertia_metric():
    """No physical candidate near the projection is closer to the input (‖L(J' − J)L‖_F)."""
    rng = np.random.default_rng(24)
    ell = 0.1
    L = np.diag([1 / ell] * 3 + [1.0])
    phi = InertialParameters.random(rng).to_phi() + rng.normal(size=10) * np.r_[0.5, [0.05] * 3, [0.01] * 6]
    assert InertialParameters.from_phi(phi).violations() or phi[0] <= 0
    projected = project_to_physical(phi, length_scale=ell)

    def distance(candidate):
        return np.linalg.norm(L @ (pseudo_inertia(candidate) - pseudo_inertia(phi)) @ L)

    best = distance(projected)
    for _ in range(2000):
        candidate = projected + rng.normal(size=10) * 1e-3 * np.abs(projected).max()
        if np.linalg.eigvalsh(L @ pseudo_inertia(candidate) @ L).min() >= 0:
            assert distance(candidate) >= best * (1 - 1e-9)
