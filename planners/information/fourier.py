r"""The fast estimator for shift-kernel sensors (the rescue beacon): Fourier-synthesised channels.

A :class:`~infoseek.envs.sensors.base.ShiftKernelSensor` has a likelihood that is a shifted
member of a one-parameter family of kernels on a periodic observation of period ``L``,

.. math::  p(z \mid \theta_n) = f_{s_n}(z - c_n),

with ``(c_n, s_n) = kernel_parameters(x, theta_n)`` for the sensor pose ``x``.

For the beacon receiver ``c_n`` is the field-line angle and ``s_n`` the signal-to-noise ratio
``rho_n`` (the noise is additive on the 2-D field, so the angular noise scale depends on each
particle's SNR); for an additive-noise sensor ``s`` is constant.

**Kernel table.** At construction the estimator samples ``f_s`` on a fine grid for shape nodes
``s_g`` equally spaced in ``u = log(1 + s)`` (spacing ``1/128``) up to the largest shape
``s_max`` (the sensor's ``max_kernel_shape``, e.g. ``beacon_v0``'s noise floor 5, or the
``max_shape`` option), and stores the Fourier coefficients
``F(k; s_g) = int f_{s_g}(d) exp(-i w_k d) dd`` (``w_k = 2 pi k / L``) up to the harmonic ``K``
beyond which every ``|F| < 1e-8``, and the kernel entropies ``h(s_g) = -int f log f``
(trapezoid rule on the fine grid). Shapes between nodes are interpolated linearly in ``u``.

**Channels.** Pose ``p`` and particle ``n`` give the spectrum
``X_n[k] = F(k; s_n) exp(-i w_k (c_n - low))``; its inverse real FFT on ``Q >= 2K + 2`` nodes is
*exactly* the kernel's probability mass ``Delta f_{s_n}(z_q - c_n)`` at the grid nodes
(a band-limited series sampled above its Nyquist rate: no stencil, no rounding of the centre,
rows summing to one). These channels feed the discrete-channel formulas
(:mod:`~infoseek.planners.information.channels`): ``H(z)`` is the periodic trapezoid rule on
the exact nodal density of the mixture (spectrally accurate), ``H(z | theta) = sum_n w_n
h(s_n)`` from the table. One and two observations share the grid (one resolution per utility);
single MIs skip the channels and sum the spectra, ``sum_n w_n X_n``, directly. The spectra are
synthesised by one compiled pass per pose (:mod:`~infoseek.planners.information.
fourier_spectra`, NumPy's bits) and kept with the channels by the belief's
:class:`~infoseek.planners.information.fourier_cache.FourierCache`.

**Cost** per pose ``O(N K)`` for the spectra plus ``O(N Q log Q)`` for the channels; per pair one
``(Q x N) (N x Q)`` matrix product. With ``beacon_v0``'s floor (``rho <= 5``): ``K = 17``,
``Q = 36``.

**Kernels sharper than the table.** Shapes above ``s_max`` occur only for an unbounded sensor
(the exact ``beacon`` receiver, whose SNR reaches ``~10^3`` within a few units of the beacon and
``~10^5`` within a fraction of one; ``max_shape`` defaults to 64 there). With an ``rng`` the
estimator resolves them: the pose sets holding such particles get the exact decomposition of
:mod:`~infoseek.planners.information.sharp_remainder` (this grid over the resolved particles
plus a stratified Monte Carlo remainder over the sharp ones and their overlap with the rest, with
its standard error in the returned ``stderr``); other sets, and every set of a sensor bounded by
the table (``beacon_v0``'s floored receiver, the bearing sensor), are computed on the grid alone
and the generator is never drawn from, so their values are the same bits with or without it.
Without an ``rng`` such shapes use the kernel of ``s_max``: the MI of a receiver with its SNR
capped at ``s_max``, a lower bound of the exact MI (data processing). The estimator then
reports the capped particles (:meth:`ShiftKernelEstimator.unresolved`) and the public
functions (:func:`~infoseek.planners.information.mutual_information`, ...) mark the value as
a lower bound and warn (:class:`~infoseek.planners.information.base.MILowerBoundWarning`), the
message saying to pass an ``rng``. Cost of a resolved set: the grid, plus ``n_samples`` draws
(default 4096) of ``k N`` likelihoods each, ~0.1-0.3 s for ``N = 250``, ``k <= 2``.
"""

from __future__ import annotations

import math
from typing import ClassVar

import numpy as np
import scipy.fft
from numpy.typing import NDArray

from infoseek.envs.sensors.base import Sensor
from infoseek.planners.information.base import BeliefMI, FloatArray, JointEntropies, MIEstimator
from infoseek.planners.information.channels import BATCH_BUDGET, entropy, joint_entropies
from infoseek.planners.information.fourier_cache import FourierCache
from infoseek.planners.information.fourier_spectra import kernel_spectra
from infoseek.planners.information.grid_entropy import entropy_sums, pair_grids
from infoseek.planners.information.quadrature import check_points
from infoseek.planners.information.sharp_remainder import sharp_mi

__all__ = ["KernelTable", "ShiftKernelEstimator"]

#: Shape-node spacing in ``u = log(1 + s)``.
SHAPE_SPACING = 1.0 / 128.0
#: Fourier coefficients below this (relative to ``F(0) = 1``) are dropped.
COEFFICIENT_TOLERANCE = 1e-8
#: Default ``max_shape`` for sensors whose shape is unbounded.
UNBOUNDED_MAX_SHAPE = 64.0
#: Largest harmonic the table keeps.
MAX_HARMONIC = 2048


class KernelTable:
    """Fourier coefficients and entropies of a kernel family on shape nodes (module docstring).

    Args:
        sensor: A shift-kernel sensor.
        max_shape: Largest shape ``s_max >= 0`` tabulated.

    Attributes:
        period: ``L``.
        harmonics: ``K`` (coefficients ``0..K`` kept).
        coefficients: ``(G, K + 1)`` ``F(k; s_g)`` (real for even kernels, else complex).
        entropies: ``(G,)`` ``h(s_g)`` in nats.
    """

    def __init__(self, sensor: Sensor, max_shape: float) -> None:
        domain = sensor.domain
        self.low = float(domain.low[0])
        self.period = float(domain.high[0]) - self.low
        self.max_shape = float(max_shape)
        top = math.log1p(self.max_shape)
        n_nodes = max(1, math.ceil(top / SHAPE_SPACING) + 1) if self.max_shape > 0 else 1
        self.shapes = np.expm1(np.linspace(0.0, top, n_nodes)) if n_nodes > 1 else np.zeros(1)
        self.node_spacing = top / (n_nodes - 1) if n_nodes > 1 else 1.0
        samples = 1024
        while True:
            coefficients, entropies = self._sample(sensor, samples)
            magnitude = np.abs(coefficients).max(axis=0)
            above = np.nonzero(magnitude >= COEFFICIENT_TOLERANCE)[0]
            harmonics = int(above.max()) if above.size else 0
            if 8 * harmonics <= samples or samples >= 16 * MAX_HARMONIC:
                break
            samples *= 2
        self.harmonics = min(max(harmonics, 1), MAX_HARMONIC)
        coefficients = coefficients[:, : self.harmonics + 1]
        if np.abs(coefficients.imag).max() < COEFFICIENT_TOLERANCE:
            coefficients = coefficients.real.copy()
        self.coefficients = coefficients
        self.entropies = entropies
        # float32 (value, slope to the next node) pairs: one row gather per particle
        slope = np.diff(coefficients, axis=0, append=coefficients[-1:])
        dtype = np.float32 if np.isrealobj(coefficients) else np.complex64
        self.rows = np.ascontiguousarray(np.stack([coefficients, slope], axis=1).astype(dtype))
        #: Whether the compiled synthesis serves the table (real coefficients, two nodes or more).
        self.compiled = dtype is np.float32 and self.shapes.size >= 2

    def _sample(self, sensor: Sensor, samples: int) -> tuple[np.ndarray, FloatArray]:
        """Coefficients ``(G, samples // 2 + 1)`` and entropies ``(G,)`` from a fine grid."""
        residual = -0.5 * self.period + self.period * np.arange(samples) / samples
        log_f = np.asarray(
            sensor.kernel_log_density(  # type: ignore[attr-defined]
                residual[None, :], self.shapes[:, None]
            ),
            dtype=np.float64,
        )
        if log_f.shape != (self.shapes.size, samples) or np.any(np.isnan(log_f)):
            raise ValueError("kernel_log_density must return finite values of the broadcast shape")
        density = np.exp(log_f)
        step = self.period / samples
        mass = density.sum(axis=1, keepdims=True) * step
        density /= mass
        log_f = log_f - np.log(mass)
        entropies = -np.sum(density * np.where(density > 0, log_f, 0.0), axis=1) * step
        # F(k) = int f(d) e^{-i w_k d} dd with d = residual; the grid starts at -L/2.
        spectrum = scipy.fft.rfft(density, axis=1) * step
        shift = np.exp(1j * np.pi * np.arange(spectrum.shape[1]))  # e^{-i w_k (-L/2)}
        return spectrum * shift, entropies

    def entropy_at(self, shapes: FloatArray) -> FloatArray:
        """``h(s)`` at arbitrary shapes (clamped to ``[0, s_max]``), linear in ``u`` between
        nodes."""
        if self.shapes.size == 1:
            return np.full(np.shape(shapes), self.entropies[0])
        u = self.shape_coordinates(shapes)
        node = np.minimum(u.astype(np.intp), self.shapes.size - 2)
        h = self.entropies
        return np.asarray(h[node] + (u - node) * (h[node + 1] - h[node]), dtype=np.float64)

    def shape_coordinates(self, shapes: FloatArray) -> FloatArray:
        """``u = log1p(clip(s, 0, s_max)) / spacing``: the shape in node units."""
        u: FloatArray = np.log1p(np.clip(shapes, 0.0, self.max_shape)) * (1.0 / self.node_spacing)
        return u

    def interpolate(self, shapes: FloatArray) -> tuple[np.ndarray, FloatArray]:
        """``(F (..., K + 1), h (...))`` at arbitrary shapes (clamped to ``[0, s_max]``).

        ``F`` is float32 (complex64 for kernels that are not even), linear in ``u``.
        """
        rows = self.rows
        if self.shapes.size == 1:
            shape = np.shape(shapes)
            return (
                np.broadcast_to(rows[0, 0], shape + (self.harmonics + 1,)),
                np.full(shape, self.entropies[0]),
            )
        u = self.shape_coordinates(shapes)
        node = np.minimum(u.astype(np.intp), self.shapes.size - 2)
        t = u - node
        pairs = rows[node]  # (..., 2, K + 1)
        coefficients: np.ndarray = pairs[..., 1, :] * t[..., None].astype(np.float32)
        coefficients += pairs[..., 0, :]
        h = self.entropies[node] + t * (self.entropies[node + 1] - self.entropies[node])
        return coefficients, h


class ShiftKernelEstimator(MIEstimator):
    """Fourier-synthesised channels for shift-kernel sensors (module docstring).

    Args:
        sensor: A sensor with ``kernel_parameters`` and ``kernel_log_density`` and a periodic
            observation.
        n_points: Grid nodes ``Q`` (``None``: ``next_fast_len(2K + 2)``, at least 16).
        max_shape: Largest shape the table resolves (``None``: the sensor's
            ``max_kernel_shape`` if finite, else 64).
        n_samples: Monte Carlo draws per pose set for kernels sharper than the table
            (:mod:`~infoseek.planners.information.sharp_remainder`), an integer ``>= 16``.
        rng: Generator of those draws. ``None``: shapes beyond ``max_shape`` are capped there
            and the value is a lower bound, reported by :meth:`unresolved` (the public
            functions then mark and warn). Never drawn from for a sensor whose shapes stay
            within the table (bounded sensors give the same values with or without it).

    Raises:
        ValueError: A bad ``max_shape``, ``n_samples`` or ``rng``.
    """

    name: ClassVar[str] = "fourier"
    required_methods: ClassVar[tuple[str, ...]] = ("kernel_parameters", "kernel_log_density")
    periodic_only: ClassVar[bool] = True
    options: ClassVar[tuple[str, ...]] = ("n_points", "max_shape", "n_samples", "rng")

    def __init__(
        self,
        sensor: Sensor,
        n_points: int | None = None,
        max_shape: float | None = None,
        n_samples: int = 4096,
        rng: np.random.Generator | None = None,
    ) -> None:
        super().__init__(sensor)
        if max_shape is None:
            bound = float(getattr(sensor, "max_kernel_shape", math.inf))
            max_shape = bound if math.isfinite(bound) else UNBOUNDED_MAX_SHAPE
        if not (math.isfinite(max_shape) and max_shape >= 0):
            raise ValueError(f"max_shape must be finite and >= 0, got {max_shape!r}")
        self.table = KernelTable(sensor, max_shape)
        points = check_points(n_points)
        if points is None:
            points = max(16, int(scipy.fft.next_fast_len(2 * self.table.harmonics + 2, real=True)))
        self.n_points = points
        self.harmonics = min(self.table.harmonics, (points - 1) // 2)
        self.log_spacing = math.log(self.table.period / points)
        self._frequencies = 2.0 * np.pi * np.arange(self.harmonics + 1) / self.table.period
        if rng is not None and not isinstance(rng, np.random.Generator):
            raise ValueError(f"rng must be a numpy.random.Generator or None, got {type(rng)}")
        if isinstance(n_samples, bool) or int(n_samples) != n_samples or n_samples < 16:
            raise ValueError(f"n_samples must be an integer >= 16, got {n_samples!r}")
        self.n_samples = int(n_samples)
        self.rng = rng
        #: Whether sharper shapes than the table's can occur (the sensor is not bounded by it).
        self.capped = float(getattr(sensor, "max_kernel_shape", math.inf)) > max_shape

    # -- per-pose work
    def _spectra(self, poses: FloatArray, belief: BeliefMI) -> tuple[np.ndarray, FloatArray]:
        """``(X (P, Q // 2 + 1, N) complex64, h (P, N))`` kernel spectra (harmonic axis before
        the particle axis; zero above ``K``) and kernel entropies."""
        centre, shape = self.sensor.kernel_parameters(poses, belief.particles)  # type: ignore[attr-defined]
        centre = np.asarray(centre, dtype=np.float64)
        shape = np.asarray(shape, dtype=np.float64)
        expected = (poses.shape[0], belief.n_particles)
        if centre.shape != expected or shape.shape != expected:
            raise ValueError(
                f"kernel_parameters returned shapes {centre.shape} and {shape.shape}, expected "
                f"{expected}"
            )
        if not (np.isfinite(centre).all() and np.isfinite(shape).all()):
            raise ValueError("kernel_parameters returned non-finite values")
        n_rows = self.n_points // 2 + 1
        if self.table.compiled:  # NumPy's log1p, one compiled pass for the rest
            return kernel_spectra(
                self.table.shape_coordinates(shape),
                centre,
                self.table.low,
                self._frequencies[1],
                self.table.rows,  # type: ignore[arg-type]
                self.table.entropies,
                self.harmonics,
                n_rows,
            )
        angle = (centre - self.table.low) * self._frequencies[1]
        coefficients, h = self.table.interpolate(shape)
        step = (np.cos(angle) - 1j * np.sin(angle)).astype(np.complex64)  # e^{-i w_1 (c - low)}
        n_poses, n = expected
        # Q // 2 + 1 rows, the ones above K zero, so the inverse real FFT on Q nodes needs no
        # padding copy.
        spectra = np.empty((n_poses, n_rows, n), dtype=np.complex64)
        spectra[:, self.harmonics + 1 :] = 0.0
        spectra[:, 0] = 1.0
        if self.harmonics >= 1:
            spectra[:, 1] = step
        for k in range(2, self.harmonics + 1):
            np.multiply(spectra[:, k - 1], step, out=spectra[:, k])
        kept = spectra[:, : self.harmonics + 1]
        kept *= np.swapaxes(coefficients[..., : self.harmonics + 1], 1, 2)
        return spectra, h

    def cache(self, belief: BeliefMI) -> FourierCache:
        """The belief's spectra and channels (one :class:`FourierCache` per belief)."""
        return belief.derived(  # type: ignore[no-any-return]
            f"fourier/{self.n_points}", lambda: FourierCache(self, belief)
        )

    def spectra(self, belief: BeliefMI, poses: FloatArray) -> tuple[np.ndarray, FloatArray]:
        """``(X (P, Q // 2 + 1, N), conditional (P,))``: kernel spectra and ``H(z | theta)``,
        cached per pose."""
        return self.cache(belief).spectra(poses)

    def channels(self, belief: BeliefMI, poses: FloatArray) -> tuple[np.ndarray, FloatArray]:
        """``(P, Q, N)`` float32 channels (cell probabilities of every particle, cell axis first)
        and ``(P,)`` conditional entropies; cached per pose."""
        return self.cache(belief).channels(poses)

    def sharp(self, belief: BeliefMI, poses: FloatArray) -> NDArray[np.bool_]:
        """``(P, N)``: whether particle ``n`` has positive weight and a kernel shape at pose
        ``p`` beyond the table's ``s_max``. Nothing for a sensor whose shapes never exceed it."""
        if not self.capped:
            return np.zeros((poses.shape[0], belief.n_particles), dtype=bool)
        _, shape = self.sensor.kernel_parameters(poses, belief.particles)  # type: ignore[attr-defined]
        return (np.asarray(shape) > self.table.max_shape) & (belief.weights > 0)

    def unresolved(self, belief: BeliefMI, poses: FloatArray) -> NDArray[np.bool_]:
        """``(P, N)``: the :meth:`sharp` particles when the estimator has no ``rng`` (their SNR
        is capped at ``s_max``, so the value is a lower bound: module docstring); nothing when
        it has one (the sharp kernels are resolved by the Monte Carlo remainder)."""
        if self.rng is not None:
            return np.zeros((poses.shape[0], belief.n_particles), dtype=bool)
        return self.sharp(belief, poses)

    def _sharp_sets(self, belief: BeliefMI, pose_sets: FloatArray) -> NDArray[np.intp]:
        """Indices of the ``(C, k, pose_dim)`` sets the Monte Carlo remainder resolves (only
        with an ``rng``)."""
        if self.rng is None or not self.capped:
            return np.empty(0, dtype=np.intp)
        n_sets, k, pose_dim = pose_sets.shape
        flags = self.sharp(belief, pose_sets.reshape(n_sets * k, pose_dim))
        return np.flatnonzero(flags.reshape(n_sets, -1).any(axis=1))

    def _resolve_sharp(
        self, belief: BeliefMI, pose_sets: FloatArray, grid: JointEntropies
    ) -> JointEntropies:
        """``grid`` with the sets holding sharp kernels replaced by the exact grid part plus
        Monte Carlo remainder (:func:`~infoseek.planners.information.sharp_remainder.sharp_mi`)."""
        sets = self._sharp_sets(belief, pose_sets)
        if sets.size == 0 or self.rng is None:
            return grid
        values, stderrs = grid.values.copy(), grid.stderrs.copy()
        entropy_z, conditional = grid.entropy.copy(), grid.conditional.copy()
        for c in sets:
            values[c], stderrs[c], conditional[c] = sharp_mi(
                self, belief, pose_sets[c], self.rng, self.n_samples
            )
            entropy_z[c] = values[c] + conditional[c]
        return JointEntropies(values, stderrs, entropy_z, conditional)

    # -- estimates
    def singles(self, belief: BeliefMI, poses: FloatArray) -> FloatArray:
        grid = JointEntropies.from_entropies(*self._single_entropies(belief, poses))
        return self._resolve_sharp(belief, poses[:, None], grid).values

    def _single_entropies(
        self, belief: BeliefMI, poses: FloatArray
    ) -> tuple[FloatArray, FloatArray]:
        """Differential ``(H(z), H(z | theta))`` of single observations (from the spectra's
        weighted sum, no channels)."""
        n = belief.n_particles
        chunk = max(1, BATCH_BUDGET // (4 * n * (self.n_points // 2 + 1)))
        weights = belief.weights.astype(np.complex64)
        entropy_z = np.empty(poses.shape[0])
        conditional = np.empty(poses.shape[0])
        for start in range(0, poses.shape[0], chunk):
            block = poses[start : start + chunk]
            part = slice(start, start + block.shape[0])
            spectra, conditional[part] = self.spectra(belief, block)
            mixture = np.matmul(spectra, weights)  # (P, Q // 2 + 1)
            density = scipy.fft.irfft(mixture.astype(np.complex128), n=self.n_points, axis=-1)
            entropy_z[part] = entropy(density, (1,)) + self.log_spacing
        return entropy_z, conditional

    def pairs(self, belief: BeliefMI, poses_a: FloatArray, poses_b: FloatArray) -> FloatArray:
        channels_a, conditional_a = self.channels(belief, poses_a)
        channels_b, conditional_b = self.channels(belief, poses_b)
        joint = _pair_joint_entropies(channels_a, channels_b, belief.weights)
        joint += 2.0 * self.log_spacing
        values = joint - conditional_a[:, None] - conditional_b[None, :]
        if self.rng is None or not self.capped:
            return values
        sharp_a = np.asarray(self.sharp(belief, poses_a).any(axis=1))
        sharp_b = np.asarray(self.sharp(belief, poses_b).any(axis=1))
        for a, b in zip(*np.nonzero(sharp_a[:, None] | sharp_b[None, :]), strict=True):
            pair = np.stack([poses_a[a], poses_b[b]])
            values[a, b] = sharp_mi(self, belief, pair, self.rng, self.n_samples)[0]
        return values

    def joint(self, belief: BeliefMI, pose_sets: FloatArray) -> JointEntropies:
        return self._resolve_sharp(belief, pose_sets, self._grid_joint(belief, pose_sets))

    def _grid_joint(self, belief: BeliefMI, pose_sets: FloatArray) -> JointEntropies:
        """:meth:`joint` on the grid alone (shapes capped at ``s_max``)."""
        n_sets, k = pose_sets.shape[:2]
        if k == 1:
            return JointEntropies.from_entropies(*self._single_entropies(belief, pose_sets[:, 0]))
        q, n = self.n_points, belief.n_particles
        per_set = 2 * k * n * q + n * q ** max(k - 1, 1) + q**k
        chunk = max(1, BATCH_BUDGET // per_set)
        entropy_z = np.empty(n_sets)
        conditional = np.zeros(n_sets)
        for start in range(0, n_sets, chunk):
            block = pose_sets[start : start + chunk]
            part = slice(start, start + block.shape[0])
            channels = []
            for j in range(k):
                channel, h = self.channels(belief, block[:, j])
                channels.append(np.swapaxes(channel, 1, 2).astype(np.float64))  # (P, N, Q)
                conditional[part] += h
            entropy_z[part] = joint_entropies(channels, belief.weights)[0] + k * self.log_spacing
        return JointEntropies.from_entropies(entropy_z, conditional)


def _pair_joint_entropies(
    channels_a: np.ndarray, channels_b: np.ndarray, weights: FloatArray
) -> FloatArray:
    """``(A, B)`` discrete joint entropies of ``(A, Q, N)`` and ``(B, Q, N)`` channels: one
    matrix product ``(A Q x N) (N x B Q)`` per chunk of ``a``."""
    n_a, q, n = channels_a.shape
    n_b = channels_b.shape[0]
    right = (channels_b * weights.astype(np.float32)).reshape(n_b * q, n)
    result = np.empty((n_a, n_b))
    chunk = max(1, BATCH_BUDGET // (n_b * q * q + n * q))
    for start in range(0, n_a, chunk):
        stop = min(start + chunk, n_a)
        left = channels_a[start:stop].reshape(-1, n)
        joint = pair_grids(left @ right.T, stop - start, n_b, q)  # float64, clamped at 1e-300
        result[start:stop] = entropy_sums(joint, np.log(joint)).reshape(stop - start, n_b)
    return result
