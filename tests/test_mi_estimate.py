"""Tests of :func:`~infoseek.planners.information._set_estimate`, the :class:`MIEstimate` of one
pose set that :func:`~infoseek.planners.information.mutual_information` returns."""

from __future__ import annotations

import numpy as np

from infoseek.envs.sensors import BearingSensor
from infoseek.planners.information import (
    JointEntropies,
    MIEstimate,
    _set_estimate,
    make_estimator,
    mutual_information,
    mutual_information_batch,
)


def test_the_estimate_of_a_set_carries_that_sets_fields() -> None:
    estimator = make_estimator("quadrature", BearingSensor(sigma=0.1))
    result = JointEntropies(
        values=np.array([0.5, 0.75]),
        stderrs=np.array([0.0, 0.125]),
        entropy=np.array([2.0, 3.0]),
        conditional=np.array([1.5, 2.25]),
    )
    estimate = _set_estimate(result, estimator, np.array([0.0, 0.25]), 1)
    assert isinstance(estimate, MIEstimate) and float(estimate) == 0.75
    assert (estimate.stderr, estimate.entropy, estimate.conditional_entropy) == (0.125, 3.0, 2.25)
    assert estimate.method == "quadrature"
    assert estimate.unresolved_mass == 0.25 and estimate.lower_bound  # unresolved: a bound
    resolved = _set_estimate(result, estimator, np.array([0.0, 0.25]), 0)
    assert float(resolved) == 0.5 and not resolved.lower_bound


def test_mutual_information_is_the_estimate_of_its_single_set() -> None:
    rng = np.random.default_rng(4)
    particles = rng.uniform(0.0, 40.0, (300, 2))
    weights = np.full(300, 1.0 / 300)
    sensor = BearingSensor(sigma=0.2)
    poses = np.array([[5.0, 5.0], [35.0, 10.0]])
    value = mutual_information(sensor, poses, particles, weights, method="quadrature")
    batch = mutual_information_batch(sensor, poses[None], particles, weights, method="quadrature")
    assert float(value) == float(batch[0]) and value.method == "quadrature"
    assert value.entropy - value.conditional_entropy == float(value)
