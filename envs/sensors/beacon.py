r"""Avalanche-rescue beacon: direction of a dipole's near field, modulo pi (section IV.B).

Field model
-----------
The target :math:`\theta = (x_a, y_a, \psi_a)` is the beacon antenna's planar position and the
angle of its axis. A vehicle at distance :math:`r` and world-frame angle :math:`\phi` from the
antenna sees, with :math:`\psi = \phi - \psi_a` and moment :math:`m`, the near-field dipole
components (the :math:`1/(\beta r)^3` terms of the paper's field, which dominate near the
source)

.. math::

    H_r = \frac{2 m \cos\psi}{r^3}, \qquad H_\psi = \frac{m \sin\psi}{r^3},

rotated into the world frame with :math:`e_r = (\cos\phi, \sin\phi)`,
:math:`e_\psi = (-\sin\phi, \cos\phi)`: :math:`H = H_r e_r + H_\psi e_\psi`
(:meth:`BeaconSensor.field`). At the antenna the field is singular; ``r`` is clamped at
:data:`MIN_DISTANCE` (``1e-3`` length units) in the magnitude, and at ``r = 0`` exactly the
direction uses :math:`\phi = 0`. This keeps every quantity finite without affecting any
physically meaningful configuration.

Measurement
-----------
Independent :math:`\mathcal N(0, s^2)` noise (``s = noise_std``) is added to each horizontal
component, :math:`\tilde H = H + \eta`, and the receiver reports the direction of the field
*line*, :math:`z = \operatorname{angle}(\tilde H) \bmod \pi \in [0, \pi)`: an oscillating field
has no sign.

Exact likelihood (folded projected normal)
------------------------------------------
Scale by the noise: :math:`X = \tilde H / s \sim \mathcal N(\mu, I_2)`, :math:`\mu = H / s`,
:math:`\rho = \lVert\mu\rVert`. For a direction :math:`\vartheta` let
:math:`\delta = \vartheta - \operatorname{angle}(\mu)`, :math:`a = \rho\cos\delta` (component of
:math:`\mu` along :math:`\vartheta`) and :math:`b = \rho\sin\delta`, so
:math:`\rho^2 = a^2 + b^2`. In polar coordinates :math:`X = t(\cos\vartheta, \sin\vartheta)`,

.. math::

    p(\vartheta) = \int_0^\infty \frac{t}{2\pi} e^{-(t^2 - 2 a t + \rho^2)/2}\,dt
      = \frac{e^{-b^2/2}}{2\pi}\Bigl(e^{-a^2/2} + a\sqrt{2\pi}\,\Phi(a)\Bigr)
      = \frac{e^{-\rho^2/2}}{2\pi} + a\,\Phi(a)\,\varphi(b),

using :math:`\int_0^\infty t e^{-(t-a)^2/2} dt = e^{-a^2/2} + a\sqrt{2\pi}\Phi(a)`. Folding
:math:`\vartheta` and :math:`\vartheta + \pi` (which flips the signs of :math:`a` and :math:`b`)
and using :math:`\Phi(a) - \Phi(-a) = \operatorname{erf}(|a|/\sqrt2)\operatorname{sign} a`,

.. math::

    p(z \mid \theta) = \frac{e^{-\rho^2/2}}{\pi}
        + |a|\,\operatorname{erf}\bigl(|a|/\sqrt2\bigr)\,\varphi(b), \qquad z \in [0, \pi).

With :math:`a = (\mu_x\cos z + \mu_y\sin z)` and :math:`b = (\mu_x\sin z - \mu_y\cos z)` no angle
of :math:`\mu` is needed. The log density is
``logaddexp(-rho^2/2 - log pi, -b^2/2 - log sqrt(2 pi) + log|a| + log erf(|a|/sqrt 2))``,
finite for any field strength (``rho`` of ``1e6`` near the beacon gives exponents of ``-5e11``,
still representable). ``|a|`` is floored at ``1e-150`` inside the logarithm: below that the
second term is smaller than the first by a factor ``< 1e-300``. ``log erf`` switches to
``log1p(-erfc)`` for arguments above 0.5 to keep full relative accuracy. Far from the beacon
(``rho -> 0``) the density tends to the uniform ``1/pi``; close to it, a sharp peak of width
``~ 1/rho`` around the field direction.

Shift-kernel form and noise floor
---------------------------------
The density depends on the particle only through the field-line angle
:math:`c = \operatorname{angle}(\mu) \bmod \pi` and the signal-to-noise ratio :math:`\rho`:
:math:`p(z \mid \theta) = f_\rho(z - c)` with the even kernel
:math:`f_\rho(\delta) = e^{-\rho^2/2}/\pi + |\rho\cos\delta|\operatorname{erf}(|\rho\cos\delta|
/\sqrt2)\,\varphi(\rho\sin\delta)` (:meth:`BeaconSensor.kernel_parameters`,
:meth:`BeaconSensor.kernel_log_density`), which the planners' Fourier MI estimator exploits.

``max_snr = c`` (default ``inf``) models a receiver whose noise standard deviation is inflated
to :math:`\max(s, |H| / c)`: the same field direction, with :math:`\rho` capped at ``c``, so no
peak is narrower than ``~1/c`` rad. :meth:`sample`, :meth:`log_likelihood`,
:meth:`bin_probabilities` and the kernel form all describe that receiver, so a capped sensor is
a consistent measurement model; ``beacon_v0``'s beliefs and planners use
``sensor.with_max_snr(5)`` while the environment measures with the exact sensor (see
:mod:`infoseek.envs.search_env`, "Filter noise floor").

Exact bin probabilities (Owen's T)
----------------------------------
The folded bin :math:`[\alpha, \beta) \subset [0, \pi)` (width :math:`w \le \pi`) is the event
that :math:`X` lies in the wedge between the rays at :math:`\alpha` and :math:`\beta` or in its
point reflection. With the inward normals :math:`n_1 = (-\sin\alpha, \cos\alpha)` and
:math:`n_2 = (\sin\beta, -\cos\beta)`, the wedge is :math:`\{n_1\cdot X \ge 0, n_2 \cdot X \ge 0\}`,
a bivariate-normal orthant with means :math:`h = n_1\cdot\mu`, :math:`k = n_2\cdot\mu` and
correlation :math:`\varrho = n_1\cdot n_2 = -\cos w`. Its probability is
:math:`\Phi_2(h, k; \varrho)`, the reflection's :math:`\Phi_2(-h, -k; \varrho)`, and the sum is
:math:`1 - \Phi(h) - \Phi(k) + 2\Phi_2(h, k; \varrho)`. Owen's (1956) formula

.. math::

    \Phi_2(h, k; \varrho) = \tfrac12\Phi(h) + \tfrac12\Phi(k) - T(h, a_h) - T(k, a_k) - \beta,
    \quad a_h = \frac{k - \varrho h}{h\sqrt{1-\varrho^2}},
    \quad a_k = \frac{h - \varrho k}{k\sqrt{1-\varrho^2}},

(:math:`\beta = \tfrac12` if :math:`hk < 0`, else 0) turns the sum into
:math:`[hk > 0] - 2T(h, a_h) - 2T(k, a_k)`. Writing, for an edge angle :math:`e`,
:math:`s_e = \mu\cdot(-\sin e, \cos e)` and :math:`t_e = \mu\cdot(\cos e, \sin e)`, one checks
:math:`n_2 + \cos w\, n_1 = \sin w\,(\cos\alpha, \sin\alpha)` and the mirror identity, so
:math:`h = s_\alpha`, :math:`k = -s_\beta`, :math:`a_h = t_\alpha / s_\alpha`,
:math:`a_k = -t_\beta / s_\beta`, and since :math:`T` is even in its first and odd in its
second argument,

.. math::

    P([\alpha, \beta)) = [s_\alpha s_\beta < 0] - G(\alpha) + G(\beta),
    \qquad G(e) = 2\,T(s_e, t_e / s_e).

Everything is per edge, with no division by :math:`\sin w`, so the formula also holds for
:math:`w \to \pi`. An edge with :math:`s_e = 0` is treated as :math:`s_e = 0^+` in both
:math:`G` and the sign test (the one-sided limits agree, the probability being continuous).
For huge :math:`\rho`, :math:`G(e) \to \operatorname{sign}(t_e/s_e)\,\Phi(-|s_e|)`, recovering the
Gaussian limit
:math:`\Phi(\rho\sin(\beta - \vartheta_\mu)) - \Phi(\rho\sin(\alpha - \vartheta_\mu))`.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray
from scipy.special import erf, erfc, owens_t

from infoseek.envs.sensors.arrays import (
    LOG_SQRT_2PI,
    as_edges,
    as_particles,
    as_points,
    check_broadcast,
    check_positive,
    check_rng,
    wrap_into,
)
from infoseek.envs.sensors.base import FloatArray, ObservationDomain
from infoseek.envs.sensors.beacon_kernel import summed_beacon_log_likelihood

__all__ = ["MIN_DISTANCE", "BeaconSensor"]

#: Smallest antenna-receiver distance used in the field magnitude (length units).
MIN_DISTANCE = 1e-3
_LOG_PI = math.log(math.pi)
_MIN_ALONG = 1e-150
_SQRT_HALF = math.sqrt(0.5)


class BeaconSensor:
    """Avalanche-beacon receiver: noisy direction of the dipole field line, modulo pi.

    Attributes:
        name: ``"beacon"``.
        pose_dim: 2 (receiver position ``(x, y)``).
        target_dim: 3 (antenna position and axis angle ``(x_a, y_a, psi_a)``).
        obs_dim: 1.
        domain: ``[0, pi)``, periodic with period ``pi``.
        moment: Dipole moment ``m`` (field strength scale).
        noise_std: Standard deviation of the noise on each horizontal field component.
        max_snr: Cap on the signal-to-noise ratio ``rho`` (``inf``: the exact receiver; module
            docstring, "Shift-kernel form and noise floor").
        max_kernel_shape: ``max_snr`` (the largest kernel shape parameter ``rho``).
    """

    name = "beacon"
    pose_dim = 2
    target_dim = 3
    obs_dim = 1

    def __init__(
        self, moment: float = 1000.0, noise_std: float = 1.0, max_snr: float = math.inf
    ) -> None:
        """Create the sensor.

        Args:
            moment: Dipole moment, finite and ``> 0``.
            noise_std: Per-component field noise standard deviation, finite and ``> 0``.
            max_snr: Signal-to-noise cap ``> 0`` (``inf``, the default: the exact receiver).

        Raises:
            ValueError: If a parameter is not finite (``max_snr`` may be ``inf``) or not positive.
            TypeError: If a parameter is not a real number.
        """
        self.moment = check_positive(moment, "moment", "BeaconSensor")
        self.noise_std = check_positive(noise_std, "noise_std", "BeaconSensor")
        if max_snr == math.inf:
            self.max_snr = math.inf
        else:
            self.max_snr = check_positive(max_snr, "max_snr", "BeaconSensor")
        self.domain = ObservationDomain(low=(0.0,), high=(math.pi,), periodic=(True,))

    @property
    def max_kernel_shape(self) -> float:
        """Largest value of the kernel shape ``rho`` (``max_snr``)."""
        return self.max_snr

    def with_max_snr(self, max_snr: float) -> BeaconSensor:
        """The same receiver with its signal-to-noise ratio capped at ``max_snr``."""
        return BeaconSensor(self.moment, self.noise_std, max_snr)

    def __repr__(self) -> str:
        cap = "" if self.max_snr == math.inf else f", max_snr={self.max_snr!r}"
        return f"BeaconSensor(moment={self.moment!r}, noise_std={self.noise_std!r}{cap})"

    # -- field --------------------------------------------------------------------------------

    def _field_xy(
        self, dx: FloatArray, dy: FloatArray, psi_a: FloatArray
    ) -> tuple[FloatArray, FloatArray]:
        """World-frame field ``(H_x, H_y)`` at offset ``(dx, dy)`` from an antenna at ``psi_a``."""
        r = np.hypot(dx, dy)
        at_antenna = r == 0.0
        r_nonzero = np.where(at_antenna, 1.0, r)
        cos_phi = np.where(at_antenna, 1.0, dx / r_nonzero)
        sin_phi = dy / r_nonzero
        scale = self.moment / np.maximum(r, MIN_DISTANCE) ** 3
        cos_a, sin_a = np.cos(psi_a), np.sin(psi_a)
        h_r = (2.0 * scale) * (cos_phi * cos_a + sin_phi * sin_a)  # 2 m cos(psi) / r^3
        h_psi = scale * (sin_phi * cos_a - cos_phi * sin_a)  # m sin(psi) / r^3
        return h_r * cos_phi - h_psi * sin_phi, h_r * sin_phi + h_psi * cos_phi

    def field(self, poses: FloatArray, targets: FloatArray) -> FloatArray:
        """Noise-free world-frame magnetic field at the receivers.

        Args:
            poses: ``(..., 2)`` receiver positions.
            targets: ``(..., 3)`` beacons ``(x_a, y_a, psi_a)``, broadcasting against ``poses``.

        Returns:
            ``(..., 2)`` field vectors ``(H_x, H_y)``.
        """
        owner = "BeaconSensor.field"
        poses = as_points(poses, "poses", 2, owner)
        targets = as_points(targets, "targets", 3, owner)
        try:
            shape = np.broadcast_shapes(poses.shape[:-1], targets.shape[:-1])
        except ValueError as error:
            raise ValueError(
                f"{owner}: batch shapes of poses {poses.shape} and targets {targets.shape} "
                "do not broadcast"
            ) from error
        hx, hy = self._field_xy(
            poses[..., 0] - targets[..., 0], poses[..., 1] - targets[..., 1], targets[..., 2]
        )
        return np.stack(np.broadcast_arrays(hx, hy), axis=-1).reshape(shape + (2,))

    def _scaled_field(
        self, poses: FloatArray, particles: FloatArray
    ) -> tuple[FloatArray, FloatArray]:
        """``mu = H / noise_std`` (capped at ``max_snr`` in norm) for every pose and particle:
        two ``(..., N)`` arrays."""
        hx, hy = self._field_xy(
            poses[..., 0, None] - particles[:, 0],
            poses[..., 1, None] - particles[:, 1],
            particles[:, 2],
        )
        inv = 1.0 / self.noise_std
        mu_x, mu_y = hx * inv, hy * inv
        if self.max_snr != math.inf:
            shrink = np.minimum(1.0, self.max_snr / np.maximum(np.hypot(mu_x, mu_y), 1e-300))
            mu_x, mu_y = mu_x * shrink, mu_y * shrink
        return mu_x, mu_y

    # -- Sensor protocol ----------------------------------------------------------------------

    def sample(
        self, poses: FloatArray, targets: FloatArray, rng: np.random.Generator
    ) -> FloatArray:
        """Draw noisy field-line directions.

        Args:
            poses: ``(..., 2)`` receiver positions.
            targets: ``(..., 3)`` beacons, broadcasting against ``poses``.
            rng: Source of the field noise.

        Returns:
            ``(..., 1)`` directions in ``[0, pi)``.
        """
        rng = check_rng(rng, "BeaconSensor.sample")
        h = self.field(poses, targets) * (1.0 / self.noise_std)  # mu
        if self.max_snr != math.inf:
            norm = np.linalg.norm(h, axis=-1, keepdims=True)
            h = h * np.minimum(1.0, self.max_snr / np.maximum(norm, 1e-300))
        noisy = h + rng.standard_normal(h.shape)
        angle = np.arctan2(noisy[..., 1], noisy[..., 0])
        return wrap_into(angle, 0.0, math.pi)[..., None]

    def log_likelihood(self, z: FloatArray, poses: FloatArray, particles: FloatArray) -> FloatArray:
        """Exact folded projected-normal ``log p(z | theta)`` for every particle.

        Args:
            z: ``(..., 1)`` observed directions (any real; the density has period ``pi``).
            poses: ``(..., 2)`` receiver positions; batch shape broadcasts against ``z``.
            particles: ``(N, 3)`` beacon hypotheses ``(x_a, y_a, psi_a)``.

        Returns:
            ``(..., N)`` log densities on ``[0, pi)`` (of the capped receiver if ``max_snr`` is
            finite).
        """
        owner = "BeaconSensor.log_likelihood"
        z = as_points(z, "z", 1, owner)
        poses = as_points(poses, "poses", 2, owner)
        particles = as_particles(particles, "particles", 3, owner)
        check_broadcast(z, poses, owner)
        mu_x, mu_y = self._scaled_field(poses, particles)
        cos_z, sin_z = np.cos(z), np.sin(z)  # (..., 1) broadcasting against (..., N)
        return _folded_log_density(mu_x * cos_z + mu_y * sin_z, mu_x * sin_z - mu_y * cos_z)

    def summed_log_likelihood(
        self,
        z: FloatArray,
        poses: FloatArray,
        particles: FloatArray,
        received: NDArray[np.bool_],
    ) -> FloatArray | None:
        """The filter's likelihood pass: for every belief, the sum of ``log p(z | theta)`` over
        the readings it received (compiled, :mod:`infoseek.envs.sensors.beacon_kernel`; bit
        for bit the masked sum of :meth:`log_likelihood` in the pinned numerical environment).

        Args:
            z: ``(G, M, 1)`` readings of ``G`` groups (an environment's agents, or one belief's
                kept history).
            poses: ``(G, M, 2)`` positions of the receivers that took them.
            particles: ``(K, N, 3)`` particles of ``K`` beliefs; belief ``k`` belongs to
                group ``k // (K / G)``.
            received: ``(K, M)`` which of its group's readings each belief received.

        Returns:
            ``(K, N)`` summed log densities, or ``None`` for a single particle of a single
            belief (NumPy then sums a contiguous column pairwise; the caller sums
            :meth:`log_likelihood`).

        Raises:
            ValueError: If a sum is NaN or ``+inf``, or the shapes do not match.
        """
        owner = "BeaconSensor.summed_log_likelihood"
        z = as_points(z, "z", 1, owner)
        poses = as_points(poses, "poses", 2, owner)
        if z.ndim != 3:
            raise ValueError(f"{owner}: z must have shape (G, M, 1), got {z.shape}")
        if np.shape(particles)[0] * np.shape(particles)[1] == 1:
            return None
        total, finite = summed_beacon_log_likelihood(
            np.ascontiguousarray(z[..., 0]),
            poses,
            np.asarray(particles, dtype=np.float64),
            np.asarray(received, dtype=np.bool_),
            (self.moment, self.noise_std, self.max_snr),
        )
        if not finite:
            raise ValueError(f"{owner}: a summed log-likelihood is NaN or +inf")
        return total

    def kernel_parameters(
        self, poses: FloatArray, particles: FloatArray
    ) -> tuple[FloatArray, FloatArray]:
        """Centre and shape of each particle's likelihood kernel (``p = f_rho(z - c)``).

        Args:
            poses: ``(..., 2)`` receiver positions.
            particles: ``(N, 3)`` beacon hypotheses.

        Returns:
            ``(centre, rho)``, each ``(..., N)``: the field-line angle in ``[0, pi)`` and the
            (capped) signal-to-noise ratio.
        """
        owner = "BeaconSensor.kernel_parameters"
        poses = as_points(poses, "poses", 2, owner)
        particles = as_particles(particles, "particles", 3, owner)
        mu_x, mu_y = self._scaled_field(poses, particles)
        centre = wrap_into(np.arctan2(mu_y, mu_x), 0.0, math.pi)
        return centre, np.hypot(mu_x, mu_y)

    def kernel_log_density(self, residual: FloatArray, shape: FloatArray) -> FloatArray:
        """``log f_rho(residual)`` of the folded projected normal (module docstring).

        Args:
            residual: ``(...)`` angles ``z - centre`` (any real; period ``pi``).
            shape: ``(...)`` signal-to-noise ratios ``rho >= 0``, broadcasting against
                ``residual``.
        """
        residual = np.asarray(residual, dtype=np.float64)
        rho = np.asarray(shape, dtype=np.float64)
        return _folded_log_density(rho * np.cos(residual), rho * np.sin(residual))

    def bin_probabilities(
        self, edges: FloatArray, poses: FloatArray, particles: FloatArray
    ) -> FloatArray:
        """Exact probability that ``z`` falls in each bin ``[edges[q], edges[q+1])``.

        Uses the per-edge Owen's T form of the folded projected-normal CDF (module docstring).

        Args:
            edges: ``(Q+1,)`` strictly increasing edges within ``[0, pi]``.
            poses: ``(..., 2)`` receiver positions.
            particles: ``(N, 3)`` beacon hypotheses.

        Returns:
            ``(..., N, Q)`` bin probabilities (rows sum to 1 when the edges span ``[0, pi]``).
        """
        owner = "BeaconSensor.bin_probabilities"
        edges = as_edges(edges, self.domain, owner)
        poses = as_points(poses, "poses", 2, owner)
        particles = as_particles(particles, "particles", 3, owner)
        mu_x, mu_y = self._scaled_field(poses, particles)
        mu_x, mu_y = mu_x[..., None], mu_y[..., None]
        cos_e, sin_e = np.cos(edges), np.sin(edges)
        across = mu_y * cos_e - mu_x * sin_e  # s_e, (..., N, Q+1)
        along = mu_x * cos_e + mu_y * sin_e  # t_e
        across = np.where(across == 0.0, np.finfo(np.float64).tiny, across)  # s_e = 0+
        with np.errstate(over="ignore"):
            ratio = along / across  # may overflow to +-inf: T(h, +-inf) is well defined
        g = 2.0 * owens_t(across, ratio)
        positive = across > 0.0
        crossing = positive[..., :-1] != positive[..., 1:]
        probs = crossing + (g[..., 1:] - g[..., :-1])
        # mu = 0 exactly (only if the field underflows): the direction is uniform.
        flat = (mu_x == 0.0) & (mu_y == 0.0)
        probs = np.where(flat, np.diff(edges) / math.pi, probs)
        return np.clip(probs, 0.0, 1.0)


def _folded_log_density(along: FloatArray, across: FloatArray) -> FloatArray:
    """``log p`` of the folded projected normal from the components of ``mu`` along and across
    the direction ``z`` (module docstring, "Exact likelihood")."""
    along = np.abs(along)
    uniform_part = -0.5 * (along * along + across * across) - _LOG_PI
    along = np.maximum(along, _MIN_ALONG)
    x = along * _SQRT_HALF
    with np.errstate(divide="ignore"):  # the branch np.where discards may be log(0)
        log_erf = np.where(x < 0.5, np.log(erf(x)), np.log1p(-erfc(x)))
    peak_part = -0.5 * across * across - LOG_SQRT_2PI + np.log(along) + log_erf
    return np.logaddexp(uniform_part, peak_part)
