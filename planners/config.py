"""Options of the planners: frozen dataclasses parsed from keyword options.

:func:`parse_options` builds a config dataclass from ``**options`` and rejects unknown ones
with a ``ValueError`` listing the valid fields; :class:`PlannerConfig` documents every option of
the mutual-information planners and validates them when the planner is built.
"""

from __future__ import annotations

import dataclasses
import math
import types
import typing
from collections.abc import Mapping
from dataclasses import dataclass
from numbers import Real
from typing import Any

import numpy as np

from infoseek.envs.sensors.base import Sensor
from infoseek.planners.coordination import PenaltySettings
from infoseek.planners.information import MIEstimator, make_estimator, methods

__all__ = ["PlannerConfig", "check_option_type", "check_positive_integers", "parse_options"]


def check_positive_integers(config: Any, names: tuple[str, ...]) -> None:
    """Raise ``ValueError`` naming the first field of ``config`` in ``names`` that is not an
    integer ``>= 1`` (a bool is not)."""
    for name in names:
        value = getattr(config, name)
        if isinstance(value, bool) or not isinstance(value, int | np.integer) or value < 1:
            raise ValueError(f"{name} must be an integer >= 1, got {value!r}")


def parse_options(config_class: type, options: Mapping[str, Any]) -> Any:
    """Build a frozen config dataclass from keyword options, each checked against its field's
    annotation first (:func:`check_option_type`); the dataclass then checks ranges.

    Raises:
        ValueError: An option that is not a field of ``config_class`` (the message lists the
            valid ones), a number of the wrong kind (``2.5`` for an integer), a non-finite
            float, or a negative ``seed``.
        TypeError: An option that is not even a number where one is expected, or of another
            wrong type (the message names it).
    """
    valid = [f.name for f in dataclasses.fields(config_class)]
    unknown = sorted(set(options) - set(valid))
    if unknown:
        raise ValueError(
            f"unknown option(s) {unknown} for {config_class.__name__}; valid options: {valid}"
        )
    hints = typing.get_type_hints(config_class)
    for name, value in options.items():
        check_option_type(name, value, hints[name])
    return config_class(**options)


def check_option_type(name: str, value: object, annotation: Any) -> None:
    """Raise unless ``value`` fits ``annotation`` (``int``: an integer, not a bool; ``float``:
    a finite real number; ``bool``, ``str``; ``X | None``: ``None`` or an ``X``); an option
    named ``seed`` must also be ``>= 0`` (NumPy's seeds)."""
    allowed = typing.get_args(annotation) if isinstance(annotation, types.UnionType) else ()
    if value is None and type(None) in allowed:
        return
    kinds = [a for a in allowed if a is not type(None)] or [annotation]
    for kind in kinds:
        if kind is bool and isinstance(value, bool | np.bool_):
            return
        if kind is str and isinstance(value, str):
            return
        if kind is int and isinstance(value, int | np.integer) and not isinstance(value, bool):
            if name == "seed" and value < 0:
                raise ValueError(f"seed must be None or a non-negative integer, got {value!r}")
            return
        if kind is float and isinstance(value, Real) and not isinstance(value, bool):
            if not math.isfinite(float(value)):
                raise ValueError(f"{name} must be a finite number, got {value!r}")
            return
        if kind not in (bool, str, int, float):
            return  # a type this check does not know: the dataclass validates it
    names = [k.__name__ for k in kinds] + (["None"] if type(None) in allowed else [])
    message = f"{name} must be {' or '.join(names)}, got {value!r}"
    if isinstance(value, Real) and not isinstance(value, bool):
        raise ValueError(message)  # a number of the wrong kind (2.5 for an integer)
    raise TypeError(message)


@dataclass(frozen=True)
class PlannerConfig:
    """Options of the mutual-information planners (every field has a documented default).

    Attributes:
        n_planning: Planning particles per vehicle (2000): each vehicle's own belief is
            reduced to at most this many equally weighted particles by systematic resampling
            with the planner's generator.
        seed: Seed of the planner's own generator (None: OS entropy).
        mi_method: Mutual-information estimator (a name in
            :data:`infoseek.planners.information.ESTIMATORS`, or ``"auto"``: ``"fft"`` for
            additive-noise sensors, ``"fourier"`` for the beacon). ``"monte_carlo"`` draws from
            the planner's generator.
        quadrature_points: Observation grid size ``n_points`` of the estimator (None: the
            estimator's default).
        grid_size: Candidate controls per control axis for continuous actions (None: 9 for a
            1-D control, 5 per axis for 2-D); discrete actions always use the env's table.
        alpha: Penalty update ``beta := alpha beta`` (0.5).
        beta: Initial penalty parameter (1.0).
        gamma: Penalty exponent of eq. 27 (2.0).
        max_iterations: Maximum coordination sweeps (20).
        tolerance: Plan-change tolerance in control units (1e-6).
        feasibility_tolerance: Accepted planned-separation shortfall at convergence (0.05 units).
        schedule: ``"gauss-seidel"`` (default, sequential) or ``"jacobi"`` (synchronous).
        agreement_weight: Jacobi agreement/proximal weight (0.1; see
            :mod:`infoseek.planners.coordination`).
        reciprocal: Jacobi reciprocal anticipation of partner moves (True).
        separation_margin: Planning separation is ``min_separation + separation_margin``
            (0.25 units), so that the inexact penalty's residual shortfall stays clear of the
            environment's constraint.
        refine: Continuous actions only: polish each vehicle's grid choice inside its grid cell
            on a cubic spline of the utility through the candidate grid (values the
            coordination already computed; no further MI), see
            :mod:`infoseek.planners.refinement` (True).
        refine_points: Search points per control axis in the cell (odd, >= 3; None: 33 for a
            one-dimensional control, 17 per axis for two).
        safety_horizon: Steps ``H`` over which the separation constraints (eq. 28) are imposed,
            each candidate's track predicted with its control held (3). ``H = 1`` is the
            paper's one-step constraint; fixed-speed airplanes closing at up to twice their
            speed cannot always turn away within one step, so the default looks 3 steps ahead.
            The utility is always the one-step MI.
        max_joint_agents: :class:`JointPlanner` only: largest team size (3; the exact joint MI
            is evaluated on an observation grid, which the MI module supports for <= 3
            observations).
        max_exhaustive: :class:`JointPlanner` only: largest number of joint candidate
            combinations searched exhaustively (81: e.g. 9 turn rates for 2 airplanes); above
            it, coordinate ascent.
    """

    n_planning: int = 2000
    seed: int | None = None
    mi_method: str = "auto"
    quadrature_points: int | None = None
    grid_size: int | None = None
    alpha: float = 0.5
    beta: float = 1.0
    gamma: float = 2.0
    max_iterations: int = 20
    tolerance: float = 1e-6
    feasibility_tolerance: float = 0.05
    schedule: str = "gauss-seidel"
    agreement_weight: float = 0.1
    reciprocal: bool = True
    separation_margin: float = 0.25
    refine: bool = True
    refine_points: int | None = None
    safety_horizon: int = 3
    max_joint_agents: int = 3
    max_exhaustive: int = 81

    def __post_init__(self) -> None:
        check_positive_integers(
            self, ("n_planning", "safety_horizon", "max_joint_agents", "max_exhaustive")
        )
        if self.quadrature_points is not None and self.quadrature_points < 2:
            raise ValueError(
                f"quadrature_points must be None or >= 2, got {self.quadrature_points}"
            )
        valid = methods()  # the registry now: an estimator registered after import counts
        if not isinstance(self.mi_method, str) or self.mi_method not in valid:
            raise ValueError(f"mi_method must be one of {list(valid)}, got {self.mi_method!r}")
        if self.refine_points is not None and (
            isinstance(self.refine_points, bool)
            or not isinstance(self.refine_points, int | np.integer)
            or self.refine_points < 3
        ):
            raise ValueError(
                f"refine_points must be None or an integer >= 3, got {self.refine_points!r}"
            )
        if self.grid_size is not None and self.grid_size < 2:
            raise ValueError(f"grid_size must be None or >= 2, got {self.grid_size}")
        if not (np.isfinite(self.separation_margin) and self.separation_margin >= 0):
            raise ValueError(f"separation_margin must be >= 0, got {self.separation_margin}")
        if not isinstance(self.refine, bool):
            raise TypeError(f"refine must be a bool, got {self.refine!r}")
        # Validate the penalty parameters once (raises ValueError naming the field).
        self.penalty_settings(1.0)

    def penalty_settings(self, min_separation: float) -> PenaltySettings:
        """The coordination settings for an environment's ``min_separation``."""
        return PenaltySettings(
            min_separation=min_separation + self.separation_margin,
            alpha=self.alpha,
            beta=self.beta,
            gamma=self.gamma,
            max_iterations=self.max_iterations,
            tolerance=self.tolerance,
            feasibility_tolerance=self.feasibility_tolerance,
            schedule=self.schedule,  # type: ignore[arg-type]
            agreement_weight=self.agreement_weight,
            reciprocal=self.reciprocal,
        )

    def make_estimator(
        self, sensor: Sensor, n_observations: int, rng: np.random.Generator
    ) -> MIEstimator:
        """The planner's MI estimator for ``sensor`` (``rng`` feeds ``"monte_carlo"``).

        Raises:
            TypeError: ``mi_method`` needs a sensor method the sensor lacks.
        """
        return make_estimator(
            self.mi_method,
            sensor,
            n_observations=n_observations,
            n_points=self.quadrature_points,
            rng=rng,
        )
