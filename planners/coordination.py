r"""Decentralised penalty coordination of the vehicles' local programs (section III.D).

Every vehicle :math:`i` chooses its control :math:`u^{(i)}_t` from a finite candidate set
(a grid over its control domain, or the environment's discrete control table); candidate
:math:`c` moves it to the predicted position :math:`x^{(i)}_{t+1}(c)`. The vehicles must keep
the separation of eq. 2, rewritten as the interconnecting constraints of eq. 28,

.. math::

    g^{(i,m)} = \bar d - \| x^{(i)}_{t+1} - x^{(m)}_{t+1} \| \le 0, \qquad m \ne i,

which are handled with the inexact penalty of eq. 27 (zero where the constraints hold,
differentiable for :math:`\gamma \ge 2`),

.. math::

    P^{(i)} = \sum_{m \ne i} \max(0, g^{(i,m)})^{\gamma}.

**Local program (eq. 29).** Holding the latest exchanged plans of the other vehicles fixed,
vehicle :math:`i` maximises

.. math::

    J^{(i)}_k(c) = V^{(i)}(c \mid \text{plans}) - \frac{1}{\beta_k}\Big( P^{(i)}(c)
        + w_a \, \| x^{(i)}_{t+1}(c) - x^{(i)}_{t+1}(c^{(i)}_{k-1}) \|^2 \Big)

over its candidates, then the plans are exchanged and :math:`\beta_{k+1} = \alpha \beta_k`
(:math:`0 < \alpha < 1`), so the constraints weigh more and more until the plans are
:math:`\epsilon`-feasible. Iteration stops when no plan moved by more than ``tolerance``
(Euclidean norm in control units) **and** the worst constraint violation
:math:`\max_{i,m} g^{(i,m)}` is at most ``feasibility_tolerance``, or after
``max_iterations`` local solves per vehicle. Requiring feasibility as well as a fixed point
matters: with a large :math:`\beta` a small violation may not yet be worth fixing, and
stopping there would return an infeasible plan that the next iterations would repair.

**Slack copies and agreement (eq. 30).** For the pairwise-node utility (eq. 22) the other
vehicles' controls enter vehicle :math:`i`'s cost. Following the paper, vehicle :math:`i`
holds a copy :math:`\tilde u^{(i)}` of *all* controls, and the agreement constraints
:math:`\tilde u^{(i)} = \tilde u^{(j)}` are penalised with the same :math:`1/\beta_k` weight.
This module does *not* solve that program; it departs from it (a documented deviation):
vehicle :math:`i` optimises its own block :math:`\tilde u^{(i)}_i` and sets every other block
:math:`\tilde u^{(i)}_j` to the latest plan exchanged by vehicle :math:`j`. That choice
minimises the agreement penalty alone, not the whole objective (the copies also enter
:math:`V^{(i)}`), so it is the limit of an infinite agreement weight: best-response dynamics on
exact copies. What it drops is the negotiation of eq. 30, in which a vehicle's preferences about
its partners' plans pull its copies, and through the agreement terms the partners, toward them.
Why it is sound: when the vehicles' beliefs coincide, the pairwise-node utilities form an exact
potential game with the team potential
:math:`\Phi = (2 - n_v) \sum_i I(z^{(i)}; \theta) + \sum_{i < j} I(z^{(i)}, z^{(j)}; \theta)`
(eq. 22 summed, the pairwise approximation of the joint MI) minus the symmetric separation
penalties :math:`\sum_{i < m} \max(0, g^{(i,m)})^{\gamma} / \beta_k`: a change of vehicle
:math:`i`'s plan changes :math:`\Phi` by exactly the change of its own objective. A
Gauss-Seidel sweep is therefore coordinate ascent on :math:`\Phi` (non-decreasing at every
local solve for a fixed :math:`\beta_k`), and on a finite candidate set it stops at a
coordinate-wise maximum, a pure Nash equilibrium. With beliefs that differ (each vehicle keeps
its own particles and subsamples its own planning particles; ``comm_range`` and
``message_loss`` make them diverge further) the potential holds only approximately and
``max_iterations`` bounds the sweeps. In the synchronous schedule the own block is penalised
against the copies the others hold of it (its previous plan):
the term :math:`w_a \|x^{(i)}_{t+1}(c) - x^{(i)}_{t+1}(c^{(i)}_{k-1})\|^2`
above, measured through the dynamics in position units (the same units as the separation
penalty), with weight ``agreement_weight`` :math:`w_a` relative to :math:`1/\beta_k`. The
pairwise utility of a candidate is then evaluated against the partner plans held in the copy.
:class:`CoordinationResult.copies` returns every vehicle's final copy; at convergence all the
copies agree with the final plans (``agreement_residual == 0``).

The agreement term vanishes at a fixed point, so converged plans solve eq. 29 exactly. It is
applied in the synchronous schedule only, together with *reciprocal anticipation* (each vehicle
assumes a partner mirrors its own displacement; again exact at a fixed point). Without them,
two vehicles drawn to the same spot step away from each other simultaneously, then both step
back, forever (a 2-cycle whose amplitude does not decay as :math:`\beta \to 0`). Even so,
Jacobi can still cycle when three or more vehicles crowd one spot; Gauss-Seidel is the default
because it converged on every synthetic problem tried. A plan frozen by the grid can keep a
residual shortfall of about one candidate spacing; planners add a separation margin.

**Schedules.** ``"jacobi"`` (synchronous): all vehicles solve against the plans of the previous
exchange, then all plans are exchanged at once. ``"gauss-seidel"`` (sequential, default):
vehicles solve in index order, each against the newest plans, including those already updated
in the current sweep. One iteration is one sweep over all vehicles in both schedules.

**Horizon.** Candidate positions may be given as ``(C, H, 2)`` tracks (the control held for
``H`` steps); the constraints of eq. 28 are then imposed at every step of the horizon
(:func:`horizon_separation_penalty`). ``H = 1`` is the paper's program.

Everything here is a pure function of arrays and callables: the planners supply the utilities.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Literal

import numpy as np
from numpy.typing import NDArray

from infoseek.envs.compiled import kernel, pairwise_sum

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

#: ``utility(i, plans) -> (C_i,)``: vehicle ``i``'s utility of each of its candidates, given the
#: plan (candidate index) of every vehicle held in ``i``'s copy; ``plans[i]`` is ``i``'s own
#: previous plan and must be ignored by the utility.
UtilityFunction = Callable[[int, IntArray], FloatArray]

SCHEDULES: tuple[str, ...] = ("jacobi", "gauss-seidel")


def separation_penalty(
    positions: FloatArray,
    other_positions: FloatArray,
    min_separation: float,
    gamma: float = 2.0,
) -> FloatArray:
    r"""Inexact penalty of eq. 27 on the collision constraints of eq. 28.

    .. math:: P = \sum_m \max(0, \bar d - \|p - q_m\|)^\gamma

    Args:
        positions: ``(..., 2)`` candidate next positions of one vehicle.
        other_positions: ``(M, 2)`` planned next positions of the other vehicles (``M`` may be 0).
        min_separation: The separation :math:`\bar d \ge 0`.
        gamma: Penalty exponent :math:`\gamma \ge 2` (differentiable penalty).

    Returns:
        ``(...)`` penalty of each candidate (0 where every constraint holds).
    """
    positions = np.asarray(positions, dtype=np.float64)
    other_positions = np.asarray(other_positions, dtype=np.float64)
    if positions.shape[-1] != 2 or other_positions.shape[-1] != 2:
        raise ValueError(
            f"positions and other_positions must end in 2, got {positions.shape}, "
            f"{other_positions.shape}"
        )
    if other_positions.ndim == 1:
        other_positions = other_positions[None, :]
    if other_positions.shape[-2] == 0:
        return np.zeros(positions.shape[:-1])
    gaps = np.linalg.norm(positions[..., None, :] - other_positions, axis=-1)  # (..., M)
    violation = np.maximum(0.0, min_separation - gaps)
    return np.sum(violation**gamma, axis=-1)


def horizon_separation_penalty(
    positions: FloatArray,
    other_positions: FloatArray,
    min_separation: float,
    gamma: float = 2.0,
) -> FloatArray:
    """Eq. 27 summed over a short prediction horizon.

    Args:
        positions: ``(..., H, 2)`` predicted positions of one vehicle's candidates at steps
            ``t+1 ... t+H``.
        other_positions: ``(M, H, 2)`` (or ``(..., M, H, 2)``) the other vehicles' planned
            positions at the same steps.
        min_separation: The separation.
        gamma: Penalty exponent.

    Returns:
        ``(...)`` ``sum_h sum_m max(0, d - ||p_h - q_{m,h}||)^gamma``; with ``H = 1`` this is
        :func:`separation_penalty`.
    """
    positions = np.asarray(positions, dtype=np.float64)
    other_positions = np.asarray(other_positions, dtype=np.float64)
    if other_positions.shape[-3] == 0:
        return np.zeros(positions.shape[:-2])
    if positions.ndim in (2, 3) and other_positions.ndim in (3, positions.ndim + 1):
        # compiled passes (_shortfalls, _row_sums), the same sums as the array expression below
        rows = positions.reshape((-1,) + positions.shape[-2:])
        others = other_positions.reshape((-1,) + other_positions.shape[-3:])
        if others.shape[0] in (1, rows.shape[0]) and rows.shape[1:] == others.shape[2:]:
            square = gamma == 2.0  # NumPy's ``** 2.0`` is a square; other powers are NumPy's
            terms = _shortfalls(
                np.ascontiguousarray(rows),
                np.ascontiguousarray(others),
                float(min_separation),
                square,
            )
            penalty = _row_sums(terms if square else terms**gamma)
            return penalty.reshape(positions.shape[:-2])  # type: ignore[no-any-return]
    gaps = np.linalg.norm(positions[..., None, :, :] - other_positions, axis=-1)  # (..., M, H)
    return np.sum(np.maximum(0.0, min_separation - gaps) ** gamma, axis=(-2, -1))


@kernel
def _shortfalls(
    positions: FloatArray, others: FloatArray, min_separation: float, square: bool
) -> FloatArray:
    """``(C, M H)`` shortfalls ``max(0, d - gap)`` (squared if ``square``) of ``(C, H, 2)`` tracks
    against ``(B, M, H, 2)`` tracks (``B = 1``: shared, ``B = C``: one set per candidate), the
    gaps ``sqrt(dx^2 + dy^2)`` as ``numpy.linalg.norm`` forms them."""
    n_rows, horizon = positions.shape[:2]
    n_others = others.shape[1]
    terms = np.empty((n_rows, n_others * horizon))
    for c in range(n_rows):
        b = 0 if others.shape[0] == 1 else c
        for m in range(n_others):
            for h in range(horizon):
                dx = positions[c, h, 0] - others[b, m, h, 0]
                dy = positions[c, h, 1] - others[b, m, h, 1]
                shortfall = min_separation - math.sqrt(dx * dx + dy * dy)
                shortfall = 0.0 if 0.0 >= shortfall else shortfall
                terms[c, m * horizon + h] = shortfall * shortfall if square else shortfall
    return terms


@kernel
def _row_sums(terms: FloatArray) -> FloatArray:
    """NumPy's pairwise sum of every row (its sum over the trailing ``(M, H)`` axes)."""
    sums = np.empty(terms.shape[0])
    for row in range(terms.shape[0]):
        sums[row] = pairwise_sum(terms[row])
    return sums


def separation_constraints(positions: FloatArray, min_separation: float) -> FloatArray:
    r"""Constraint values :math:`g^{(i,m)} = \bar d - \|x^{(i)} - x^{(m)}\|` of eq. 28.

    Args:
        positions: ``(A, 2)`` planned positions.
        min_separation: The separation :math:`\bar d`.

    Returns:
        ``(A, A)`` constraint values; the diagonal (no self-constraint) is ``-inf``.
    """
    positions = np.asarray(positions, dtype=np.float64)
    gaps = np.linalg.norm(positions[:, None, :] - positions[None, :, :], axis=-1)
    g = min_separation - gaps
    np.fill_diagonal(g, -np.inf)
    return g


def max_violation(positions: FloatArray, min_separation: float) -> float:
    """Worst constraint violation ``max(0, max_{i != m} g^{(i,m)})`` (0 when feasible)."""
    positions = np.asarray(positions, dtype=np.float64)
    if positions.shape[0] < 2:
        return 0.0
    return float(max(0.0, np.max(separation_constraints(positions, min_separation))))


@kernel
def _worst_violation(tracks: FloatArray, min_separation: float) -> float:
    """``max(0, max_{h, i != m} d - ||x_i(h) - x_m(h)||)`` of ``(A, H, 2)`` tracks (the norms as
    :func:`separation_constraints` forms them; a maximum is exact in any order)."""
    worst = 0.0
    for h in range(tracks.shape[1]):
        for i in range(tracks.shape[0]):
            for m in range(tracks.shape[0]):
                if m != i:
                    dx = tracks[i, h, 0] - tracks[m, h, 0]
                    dy = tracks[i, h, 1] - tracks[m, h, 1]
                    worst = max(worst, min_separation - math.sqrt(dx * dx + dy * dy))
    return worst


@dataclass(frozen=True)
class PenaltySettings:
    """Parameters of the decentralised penalty method.

    Attributes:
        min_separation: Planning separation :math:`\\bar d` of eq. 28 (>= 0).
        alpha: Penalty parameter update :math:`\\beta := \\alpha\\beta`, in (0, 1).
        beta: Initial penalty parameter :math:`\\beta_1 > 0` (the penalty weight is 1/beta).
        gamma: Penalty exponent of eq. 27, >= 2.
        max_iterations: Maximum number of sweeps (local solves per vehicle), >= 1.
        tolerance: Plans whose controls moved by at most this (Euclidean norm, control units)
            count as unchanged.
        feasibility_tolerance: Largest constraint value ``g`` (distance units) accepted at
            convergence.
        schedule: ``"jacobi"`` (synchronous) or ``"gauss-seidel"`` (sequential).
        agreement_weight: Weight ``w_a >= 0`` (relative to 1/beta) of the agreement penalty between
            a vehicle's own block and the copies the others hold of it (eq. 30; see module doc).
    """

    min_separation: float
    alpha: float = 0.5
    beta: float = 1.0
    gamma: float = 2.0
    max_iterations: int = 20
    tolerance: float = 1e-6
    feasibility_tolerance: float = 1e-3
    schedule: Literal["jacobi", "gauss-seidel"] = "gauss-seidel"
    agreement_weight: float = 0.1
    reciprocal: bool = True

    def __post_init__(self) -> None:
        if not (np.isfinite(self.min_separation) and self.min_separation >= 0):
            raise ValueError(f"min_separation must be finite and >= 0, got {self.min_separation}")
        if not 0.0 < self.alpha < 1.0:
            raise ValueError(f"alpha must be in (0, 1), got {self.alpha}")
        if not (np.isfinite(self.beta) and self.beta > 0):
            raise ValueError(f"beta must be finite and > 0, got {self.beta}")
        if not (np.isfinite(self.gamma) and self.gamma >= 2.0):
            raise ValueError(f"gamma must be finite and >= 2, got {self.gamma}")
        if int(self.max_iterations) != self.max_iterations or self.max_iterations < 1:
            raise ValueError(f"max_iterations must be an integer >= 1, got {self.max_iterations}")
        if not (np.isfinite(self.tolerance) and self.tolerance >= 0):
            raise ValueError(f"tolerance must be finite and >= 0, got {self.tolerance}")
        if not (np.isfinite(self.feasibility_tolerance) and self.feasibility_tolerance >= 0):
            raise ValueError(
                f"feasibility_tolerance must be finite and >= 0, got {self.feasibility_tolerance}"
            )
        if self.schedule not in SCHEDULES:
            raise ValueError(f"schedule must be one of {SCHEDULES}, got {self.schedule!r}")
        if not (np.isfinite(self.agreement_weight) and self.agreement_weight >= 0):
            raise ValueError(
                f"agreement_weight must be finite and >= 0, got {self.agreement_weight}"
            )


@dataclass(frozen=True)
class CoordinationResult:
    """Outcome of :func:`coordinate`.

    Attributes:
        indices: ``(A,)`` chosen candidate index of every vehicle.
        controls: ``(A, control_dim)`` chosen controls.
        positions: ``(A, 2)`` predicted next positions under the chosen controls.
        utilities: ``(A,)`` utility of each final plan, evaluated against the final copy.
        penalties: ``(A,)`` separation penalty ``P`` of each final plan against the final plans.
        copies: ``(A, A)`` slack copies: ``copies[i, j]`` is the plan of vehicle ``j`` held by
            vehicle ``i`` in its last local solve (``copies[i, i]`` is its own final plan).
        agreement_residual: Largest control distance between a copy and the final plan of that
            vehicle (0 when the copies agree, always the case after convergence).
        iterations: Number of sweeps performed.
        converged: Whether the stopping rule (no plan change and feasible) was met.
        beta: Penalty parameter of the last sweep.
        max_violation: Worst constraint value ``max(0, g)`` of the final plans.
        changes: Largest plan change (control units) of every sweep.
    """

    indices: IntArray
    controls: FloatArray
    positions: FloatArray
    utilities: FloatArray
    penalties: FloatArray
    copies: IntArray
    agreement_residual: float
    iterations: int
    converged: bool
    beta: float
    max_violation: float
    changes: tuple[float, ...] = field(default_factory=tuple)


def _validate_candidates(
    candidate_controls: Sequence[FloatArray], candidate_positions: Sequence[FloatArray]
) -> tuple[list[FloatArray], list[FloatArray]]:
    if len(candidate_controls) != len(candidate_positions):
        raise ValueError(
            "candidate_controls and candidate_positions need one entry per vehicle, got "
            f"{len(candidate_controls)} and {len(candidate_positions)}"
        )
    if len(candidate_controls) == 0:
        raise ValueError("candidate_controls: need at least one vehicle")
    controls_out, positions_out = [], []
    for i, (u, x) in enumerate(zip(candidate_controls, candidate_positions, strict=True)):
        u = np.asarray(u, dtype=np.float64)
        x = np.asarray(x, dtype=np.float64)
        if u.ndim != 2 or u.shape[0] == 0:
            raise ValueError(f"candidate_controls[{i}] must be (C, control_dim), got {u.shape}")
        if x.ndim == 2:
            x = x[:, None, :]
        if x.ndim != 3 or x.shape[0] != u.shape[0] or x.shape[2] != 2:
            raise ValueError(
                f"candidate_positions[{i}] must have shape ({u.shape[0]}, 2) or "
                f"({u.shape[0]}, H, 2), got {x.shape}"
            )
        if not (np.isfinite(u).all() and np.isfinite(x).all()):
            raise ValueError(f"vehicle {i}: candidate controls/positions must be finite")
        controls_out.append(u)
        positions_out.append(x)
    return controls_out, positions_out


def local_objective(
    utilities: FloatArray,
    positions: FloatArray,
    other_positions: FloatArray,
    previous_position: FloatArray | None,
    beta: float,
    settings: PenaltySettings,
) -> FloatArray:
    """The objective ``J`` of eq. 29 (to maximise) for a batch of candidates of one vehicle.

    Args:
        utilities: ``(C,)`` utility of each candidate.
        positions: ``(C, 2)`` predicted next position of each candidate.
        other_positions: ``(M, 2)`` latest plans' positions of the other vehicles.
        previous_position: ``(2,)`` position of the vehicle's previous plan (the copy the others
            hold of it), or None for no agreement term.
        beta: Current penalty parameter.
        settings: Penalty settings.

    Returns:
        ``(C,)`` utility minus (1/beta) times (separation penalty + agreement penalty).
    """
    positions = np.asarray(positions, dtype=np.float64)
    other_positions = np.asarray(other_positions, dtype=np.float64)
    if positions.ndim == 2:  # (C, 2): a one-step horizon
        positions = positions[:, None, :]
        other_positions = other_positions[..., None, :]
        if previous_position is not None:
            previous_position = np.asarray(previous_position)[None, :]
    penalty = horizon_separation_penalty(
        positions, other_positions, settings.min_separation, settings.gamma
    )
    if previous_position is not None and settings.agreement_weight > 0:
        penalty = penalty + settings.agreement_weight * np.sum(
            (positions[:, 0, :] - np.asarray(previous_position)[0]) ** 2, axis=-1
        )
    return np.asarray(utilities, dtype=np.float64) - penalty / beta


def coordinate(
    candidate_controls: Sequence[FloatArray],
    candidate_positions: Sequence[FloatArray],
    utility: UtilityFunction,
    settings: PenaltySettings,
    initial_indices: IntArray | Sequence[int] | None = None,
) -> CoordinationResult:
    """Run the decentralised penalty method over finite candidate sets.

    Args:
        candidate_controls: Per vehicle, ``(C_i, control_dim)`` candidate controls.
        candidate_positions: Per vehicle, ``(C_i, 2)`` predicted next positions.
        utility: ``utility(i, plans) -> (C_i,)`` (see :data:`UtilityFunction`). Called once per
            local solve; cache inside it when the utility does not depend on the plans.
        settings: Penalty method parameters.
        initial_indices: ``(A,)`` initial plans (the first exchange). Default: every vehicle's
            unpenalised argmax of ``utility(i, nominal)``, where ``nominal[j]`` is vehicle
            ``j``'s candidate closest to the centre of its candidate controls (straight flight,
            coasting) -- the plan a vehicle assumes for a partner before any exchange.

    Returns:
        The final plans and diagnostics.
    """
    controls, positions = _validate_candidates(candidate_controls, candidate_positions)
    if initial_indices is None:
        plans = _nominal_best_plans(controls, utility)
    else:
        plans = _checked_initial_indices(initial_indices, controls)
    return _penalty_ascent(plans, utility, controls, positions, settings)


def _nominal_best_plans(controls: list[FloatArray], utility: UtilityFunction) -> IntArray:
    """Every vehicle's unpenalised argmax of ``utility(i, nominal)``, ``nominal[j]`` being
    vehicle ``j``'s candidate closest to the centre of its candidate controls."""
    nominal = np.array(
        [int(np.argmin(np.linalg.norm(u - u.mean(axis=0), axis=1))) for u in controls],
        dtype=np.int64,
    )
    return np.array(
        [
            int(np.argmax(_checked_utility(utility, i, nominal, controls[i].shape[0])))
            for i in range(len(controls))
        ],
        dtype=np.int64,
    )


def _checked_initial_indices(
    initial_indices: IntArray | Sequence[int], controls: list[FloatArray]
) -> IntArray:
    """A copy of ``initial_indices`` as ``(A,)`` int64 plans, each a valid candidate index.

    Raises:
        ValueError: Wrong shape, or an index outside its vehicle's candidates.
    """
    n_vehicles = len(controls)
    plans = np.asarray(initial_indices, dtype=np.int64).copy()
    if plans.shape != (n_vehicles,):
        raise ValueError(f"initial_indices must have shape ({n_vehicles},), got {plans.shape}")
    for i in range(n_vehicles):
        if not 0 <= plans[i] < controls[i].shape[0]:
            raise ValueError(
                f"initial_indices[{i}] = {plans[i]} outside [0, {controls[i].shape[0]})"
            )
    return plans


def _penalty_ascent(
    plans: IntArray,
    utility: UtilityFunction,
    controls: list[FloatArray],
    positions: list[FloatArray],
    settings: PenaltySettings,
) -> CoordinationResult:
    """The sweeps of :func:`coordinate` from the first exchange ``plans``, with ``beta``
    shrinking by ``alpha`` after every sweep that did not meet the stopping rule."""
    n_vehicles = len(controls)
    copies = np.tile(plans, (n_vehicles, 1))
    beta = settings.beta
    changes: list[float] = []
    converged = False
    iterations = 0
    local_utilities = np.zeros(n_vehicles)
    last_beta = beta
    fleet = _fleet_tracks(positions, settings)
    for iteration in range(1, settings.max_iterations + 1):
        iterations = iteration
        last_beta = beta
        new_plans = _sweep(
            plans, copies, local_utilities, utility, controls, positions, fleet, beta, settings
        )
        change = _largest_change(controls, plans, new_plans)
        changes.append(change)
        plans = new_plans
        violation = _horizon_violation(_planned_tracks(positions, plans), settings.min_separation)
        if change <= settings.tolerance and violation <= settings.feasibility_tolerance:
            converged = True
            break
        beta *= settings.alpha
    return _coordination_result(
        controls,
        positions,
        plans,
        copies,
        local_utilities,
        settings,
        iterations=iterations,
        converged=converged,
        beta=last_beta,
        changes=changes,
    )


def _sweep(
    plans: IntArray,
    copies: IntArray,
    local_utilities: FloatArray,
    utility: UtilityFunction,
    controls: list[FloatArray],
    positions: list[FloatArray],
    fleet: FloatArray | None,
    beta: float,
    settings: PenaltySettings,
) -> IntArray:
    """One sweep of local solves (eq. 29) over the vehicles in index order; returns the new
    plans and writes every vehicle's copy into ``copies`` and the utility of its new plan into
    ``local_utilities``."""
    exchanged = plans.copy()  # what every vehicle received at the last exchange
    new_plans = plans.copy()
    for i in range(len(controls)):
        view = new_plans if settings.schedule == "gauss-seidel" else exchanged
        copy_i = view.copy()
        copies[i] = copy_i
        u_i = _checked_utility(utility, i, copy_i, controls[i].shape[0])
        if fleet is not None:  # Gauss-Seidel, gamma = 2: one compiled pass
            best = int(
                _gauss_seidel_choice(
                    u_i, fleet, copy_i, i, int(exchanged[i]), beta, settings.min_separation
                )
            )
        else:
            best = _local_choice(i, u_i, positions, copy_i, exchanged, beta, settings)
        new_plans[i] = best
        copies[i, i] = best
        local_utilities[i] = u_i[best]
    return new_plans


def _largest_change(controls: list[FloatArray], plans: IntArray, new_plans: IntArray) -> float:
    """Largest control distance between a vehicle's new plan and its previous one."""
    return max(
        _norm(controls[i][new_plans[i]] - controls[i][plans[i]]) for i in range(len(controls))
    )


def _planned_tracks(positions: list[FloatArray], plans: IntArray) -> FloatArray:
    """``(A, H, 2)`` predicted tracks of every vehicle's planned candidate."""
    return np.array([positions[i][plans[i]] for i in range(len(positions))])


def _coordination_result(
    controls: list[FloatArray],
    positions: list[FloatArray],
    plans: IntArray,
    copies: IntArray,
    local_utilities: FloatArray,
    settings: PenaltySettings,
    *,
    iterations: int,
    converged: bool,
    beta: float,
    changes: list[float],
) -> CoordinationResult:
    """The :class:`CoordinationResult` of the final ``plans`` (penalties, agreement residual and
    violation evaluated on them) and the given sweep diagnostics."""
    final_tracks = _planned_tracks(positions, plans)  # (A, H, 2)
    return CoordinationResult(
        indices=plans,
        controls=np.array([controls[i][plans[i]] for i in range(len(controls))]),
        positions=final_tracks[:, 0, :],
        utilities=local_utilities.copy(),
        penalties=_final_penalties(final_tracks, settings),
        copies=copies,
        agreement_residual=_agreement_residual(controls, copies, plans),
        iterations=iterations,
        converged=converged,
        beta=beta,
        max_violation=_horizon_violation(final_tracks, settings.min_separation),
        changes=tuple(changes),
    )


def _final_penalties(final_tracks: FloatArray, settings: PenaltySettings) -> FloatArray:
    """``(A,)`` separation penalty of every vehicle's ``(H, 2)`` track against the others'."""
    return np.array(
        [
            horizon_separation_penalty(
                final_tracks[i],
                np.delete(final_tracks, i, axis=0),
                settings.min_separation,
                settings.gamma,
            )
            for i in range(final_tracks.shape[0])
        ]
    )


def _agreement_residual(controls: list[FloatArray], copies: IntArray, plans: IntArray) -> float:
    """Largest control distance between a copy ``copies[i, j]`` and vehicle ``j``'s plan."""
    residual = 0.0
    n_vehicles = len(controls)
    for i in range(n_vehicles):
        for j in range(n_vehicles):
            residual = max(residual, _norm(controls[j][copies[i, j]] - controls[j][plans[j]]))
    return residual


def _local_choice(
    i: int,
    u_i: FloatArray,
    positions: list[FloatArray],
    copy_i: IntArray,
    exchanged: IntArray,
    beta: float,
    settings: PenaltySettings,
) -> int:
    """Vehicle ``i``'s best candidate for eq. 29 against the plans ``copy_i`` (the previous plan
    on ties)."""
    others = np.array([positions[j][copy_i[j]] for j in range(len(positions)) if j != i]).reshape(
        -1, *positions[i].shape[1:]
    )
    if settings.schedule == "jacobi" and settings.reciprocal and others.shape[0] > 0:
        # Reciprocal anticipation: partner j is assumed to mirror my displacement.
        displacement = positions[i] - positions[i][exchanged[i]]  # (C_i, H, 2)
        others = others[None, :, :] - displacement[:, None, :]
    anchor = positions[i][exchanged[i]] if settings.schedule == "jacobi" else None
    objective = local_objective(u_i, positions[i], others, anchor, beta, settings)
    best = int(np.argmax(objective))
    # Keep the previous plan on ties (no spurious changes).
    if objective[exchanged[i]] >= objective[best]:
        best = int(exchanged[i])
    return best


def _fleet_tracks(positions: list[FloatArray], settings: PenaltySettings) -> FloatArray | None:
    """``(A, C, H, 2)`` candidate tracks of every vehicle when :func:`_gauss_seidel_choice`
    serves the program (Gauss-Seidel, ``gamma = 2``, one candidate count), else ``None``."""
    if settings.schedule != "gauss-seidel" or settings.gamma != 2.0:
        return None
    if any(track.shape != positions[0].shape for track in positions):
        return None
    return np.ascontiguousarray(np.stack(positions))


@kernel
def _gauss_seidel_choice(
    utilities: FloatArray,
    fleet: FloatArray,
    plans: IntArray,
    vehicle: int,
    previous: int,
    beta: float,
    min_separation: float,
) -> int:
    """:func:`_local_choice` of a Gauss-Seidel sweep with ``gamma = 2``: the objective
    ``u - P / beta`` of every candidate (the penalty of :func:`horizon_separation_penalty`
    against the partners' planned tracks in vehicle order, summed as NumPy sums it), its first
    maximum, and the previous plan kept on ties."""
    n_vehicles, n_candidates, horizon = fleet.shape[:3]
    terms = np.empty((n_vehicles - 1) * horizon)
    objective = np.empty(n_candidates)
    best = 0
    for c in range(n_candidates):
        slot = 0
        for j in range(n_vehicles):
            if j == vehicle:
                continue
            for h in range(horizon):
                dx = fleet[vehicle, c, h, 0] - fleet[j, plans[j], h, 0]
                dy = fleet[vehicle, c, h, 1] - fleet[j, plans[j], h, 1]
                shortfall = min_separation - math.sqrt(dx * dx + dy * dy)
                shortfall = 0.0 if 0.0 >= shortfall else shortfall
                terms[slot] = shortfall * shortfall
                slot += 1
        objective[c] = utilities[c] - pairwise_sum(terms) / beta
        # numpy.argmax: the first maximum, or the first NaN
        if objective[best] == objective[best] and not objective[c] <= objective[best]:
            best = c
    if objective[previous] >= objective[best]:
        best = previous
    return best


def _horizon_violation(tracks: FloatArray, min_separation: float) -> float:
    """Worst constraint value over the steps of ``(A, H, 2)`` tracks (0 when feasible)."""
    tracks = np.ascontiguousarray(tracks, dtype=np.float64)
    return float(_worst_violation(tracks, float(min_separation)))


def _norm(vector: FloatArray) -> float:
    """``numpy.linalg.norm`` of a 1-D float64 vector: the square root of its BLAS dot."""
    return math.sqrt(float(vector.dot(vector)))


def _checked_utility(
    utility: UtilityFunction, i: int, plans: IntArray, n_candidates: int
) -> FloatArray:
    values = np.asarray(utility(i, plans.copy()), dtype=np.float64)
    if values.shape != (n_candidates,):
        raise ValueError(
            f"utility for vehicle {i} must return shape ({n_candidates},), got {values.shape}"
        )
    if not np.isfinite(values).all():
        raise ValueError(f"utility for vehicle {i} returned non-finite values")
    return values
