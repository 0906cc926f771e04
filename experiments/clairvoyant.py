r"""A clairvoyant reference for ``bearings_v0``: airplanes that know where the target is.

Not a planner (it reads the true target, which planners never do) and not a bound (it is one
strategy among many); it answers "how fast do vehicles localise that need no search at all,
only the geometry of good bearings?". Each step every airplane, in turn (the later ones seeing
the earlier ones' choices), flies the turn rate, held for the next ``lookahead`` steps, that
maximises the log-determinant of the team's Fisher information about the true target position
:math:`t` (D-optimal design): with a bearing from :math:`p` to :math:`t`, at range :math:`r` and
unit normal :math:`u` to the line of sight, the information is

.. math::

    J(p) = \frac{u u^\top}{\sigma^2 r^2},

summed over every observation so far, every planned observation of the vehicles already
decided and the candidate's, on top of the uniform prior's information
:math:`\mathrm{diag}(12 / w^2, 12 / h^2)` (the inverse covariance of the uniform distribution
on the ``w x h`` domain). :math:`1/\sigma^2` is the Fisher information of a Gaussian bearing
(the wrapped noise carries slightly less). Separation constraints are ignored.

Use it as ``infoseek bench --env bearings_v0 --planner
infoseek.experiments.clairvoyant:fisher_reference``. The time to localise is still measured on
agent 0's particle belief, which is updated with the observations as for every planner.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

CLAIRVOYANT_LABEL = "infoseek.experiments.clairvoyant:fisher_reference"
"""Its ``--planner`` label (the factory :func:`fisher_reference`)."""
CANDIDATE_TURNS = 9
"""Turn rates tried per vehicle, evenly spaced over the airplane's range."""
LOOKAHEAD = 5
"""Steps a candidate turn rate is held for."""


class ClairvoyantFisherReference:
    """Greedy D-optimal flight toward the true target (module docstring).

    Args:
        env: A ``bearings_v0`` environment (parallel API); its true target is read every step.
        lookahead: Steps a candidate turn rate is held for (>= 1).
    """

    def __init__(self, env: Any, lookahead: int = LOOKAHEAD) -> None:
        if isinstance(lookahead, bool) or not isinstance(lookahead, int) or lookahead < 1:
            raise ValueError(f"lookahead must be an int >= 1, got {lookahead!r}")
        self.env = env.unwrapped
        self.config = self.env.config
        sigma = getattr(self.config.sensor, "sigma", None)
        if sigma is None or not hasattr(self.config.vehicle, "max_turn_rate"):
            raise TypeError("env: the clairvoyant reference needs bearing sensors on airplanes")
        self.inverse_variance = 1.0 / float(sigma) ** 2
        self.lookahead = lookahead
        turn = float(self.config.vehicle.max_turn_rate)
        self.turns = np.linspace(-turn, turn, CANDIDATE_TURNS)[:, None]
        width = self.config.space.high_array[:2] - self.config.space.low_array[:2]
        self.prior = np.diag(12.0 / width**2)
        self.information = self.prior.copy()

    def fisher(self, positions: np.ndarray, target: np.ndarray) -> np.ndarray:
        """``(..., 2, 2)`` Fisher information of one bearing from each of ``(..., 2)``
        positions."""
        d = target - positions
        r2 = np.maximum(np.sum(d * d, axis=-1), 1e-12)
        normal = np.stack([-d[..., 1], d[..., 0]], axis=-1)
        scale = self.inverse_variance / (r2 * r2)
        return scale[..., None, None] * normal[..., :, None] * normal[..., None, :]

    def act(self, observations: Mapping[str, Any], infos: Mapping[str, Any]) -> dict[str, Any]:
        """This step's turn rates (every agent in ``observations``)."""
        target = np.asarray(self.env.true_target(), float)[:2]
        agents = list(observations)
        if not agents:
            return {}
        states = np.asarray(infos[agents[0]]["vehicle_states"], float)
        self.information = self.information + self.fisher(states[:, :2], target).sum(axis=0)
        planned = self.information.copy()
        actions: dict[str, Any] = {}
        for agent in agents:
            index = self.env.possible_agents.index(agent)
            track = self._tracks(states[index])  # (C, L, 2)
            gains = self.fisher(track, target).sum(axis=1)  # (C, 2, 2)
            best = int(np.argmax(np.linalg.slogdet(planned + gains)[1]))
            planned = planned + gains[best]
            actions[agent] = self.turns[best].astype(np.float32)
        return actions

    def _tracks(self, state: np.ndarray) -> np.ndarray:
        """``(C, L, 2)`` positions of every candidate turn rate held for ``lookahead`` steps."""
        current = np.broadcast_to(state, (self.turns.shape[0], state.size))
        points = []
        for _ in range(self.lookahead):
            current = self.config.vehicle.step(current, self.turns, self.config.dt)
            points.append(current[:, :2])
        return np.stack(points, axis=1)

    def reset(self) -> None:
        """Forget the accumulated information (a new episode)."""
        self.information = self.prior.copy()


def fisher_reference(
    env: Any, seed: int | None = None, **options: Any
) -> ClairvoyantFisherReference:
    """The ``--planner`` factory (``seed`` is unused: the reference draws nothing)."""
    return ClairvoyantFisherReference(env, **options)
