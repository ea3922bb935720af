"""Discrete Dynamic Movement Primitives (DMP) for end-effector trajectories (paper §III-D, §III-E).

Model (paper Eq. 1–3, after Ijspeert et al. 2013, "Dynamical Movement Primitives: Learning Attractor
Models for Motor Behaviors", Neural Computation 25(2)), one independent copy per dimension::

    τ² ÿ = α_y (β_y (g − y) − τ ẏ) + f                                   (Eq. 1)
    f(x, g) = [Σ_i Ψ_i(x) w_i / Σ_i Ψ_i(x)] · x · (g − y0),   τ ẋ = −α_x x    (Eq. 2)
    Ψ_i(x) = exp(−(x − c_i)² / (2 σ_i²))                                  (Eq. 3)

with the paper's hyper-parameters N = 100, α_y = 60, β_y = α_y / 4, α_x = 1, x0 = 1. Eq. 3 is printed
in the paper as ``exp(−1 / (2σ²(x − c)²))``; we read it as the usual Gaussian above, the form used by
Ijspeert et al. 2013 (there written with h_i = 1 / (2σ_i²)).

Dimensions are the Cartesian end-effector position (x, y, z in metres, world frame) and, optionally,
the orientation as Euler angles in radians (§III-A.3). Each dimension is learned and integrated
independently; Euler angles must be unwrapped (``np.unwrap``) before learning so that they are
continuous.

Why not ``movement_primitives`` (0.9.1): its ``DMP`` cannot express the paper's model without
rewriting most of it. (1) Its forcing term is ``x · Σψw/Σψ`` without the ``(g − y0)`` factor of
Eq. 2, so trajectories are not rescaled when the goal moves (only its optional "smooth scaling"
variant touches ``g − y0``, in a different way). (2) ``DMP`` hard-codes the canonical-system constant
so that the phase reaches 0.01 at the end of the movement (α_x ≈ 4.6), not the paper's α_x = 1, and
rebuilds the forcing term whenever the execution time is set. (3) ``imitate`` fits the weights with
one global ridge regression, not the locally weighted regression the paper cites. (4) Its ``step``
advances by a fixed ``dt_`` and importing ``movement_primitives.dmp`` pulls in ``pytransform3d``.
Only the Euler/RK4 integration loop would have been reused, so this module implements the model
directly in numpy (about as long as the adapter would have been) and adds no dependency.

Degenerate goal offset: if ``g − y0`` of the demonstration is (almost) zero in a dimension, the
scaled forcing term of Eq. 2 cannot represent the demonstration (the locally weighted regression
divides by ``(g − y0)²``) and any later goal change would amplify the shape by ``1 / (g − y0)``.
Such dimensions fall back to the unscaled forcing term ``f = Σψw/Σψ · x`` (a known weakness of the
scaled form; Pastor et al., ICRA 2009, reformulate the DMP partly to avoid it): the learned shape is
then replayed unscaled, offset to the new start and goal. The choice is recorded per dimension in
:attr:`DMPParameters.goal_scaled`. In a scaled dimension, a rollout whose own goal equals its start
gets a zero forcing term, exactly as Eq. 2 prescribes.
"""

from __future__ import annotations

import dataclasses
import json
import math
from collections import deque
from dataclasses import dataclass
from pathlib import Path

import numpy as np

N_BASIS = 100
"""Number of Gaussian basis functions N (§III-D)."""
ALPHA_Y = 60.0
"""Gain α_y of the transformation system (§III-D)."""
BETA_Y = ALPHA_Y / 4.0
"""Gain β_y = α_y / 4 of the transformation system (§III-D), critical damping."""
ALPHA_X = 1.0
"""Decay constant α_x of the canonical system (§III-D)."""
X0 = 1.0
"""Initial phase x0 (§III-D)."""
BACKUP_POINTS = 10
"""Trajectory points Alg. 2 goes back after an unwanted collision (§III-E)."""
FORMAT_VERSION = 1
"""Version of the file format written by :func:`save_parameters`."""

_FORMAT_KIND = "taskcond.dmp"
_META_FIELDS = frozenset({"arrays", "n_dims", "n_basis", "alpha_y", "beta_y", "alpha_x", "x0", "tau"})
_ARRAY_FIELDS = frozenset({"weights", "centres", "widths", "y0", "goal", "goal_scaled"})
_GOAL_TOLERANCE = 1e-3
"""Relative tolerance below which ``|g − y0|`` counts as zero (fraction of the demo's excursion)."""


def _finite_array(name: str, value: object, ndim: int) -> np.ndarray:
    """``value`` as a float array with ``ndim`` dimensions, free of NaN and inf, or ValueError."""
    try:
        array = np.array(value, dtype=float)
    except (TypeError, ValueError) as error:
        raise ValueError(f"{name} must be a numeric array: {error}") from None
    if array.ndim != ndim:
        raise ValueError(f"{name} must be {ndim}-D, got shape {array.shape}")
    if not np.all(np.isfinite(array)):
        raise ValueError(f"{name} contains NaN or inf")
    return array


def _vector(name: str, value: object, size: int) -> np.ndarray:
    """``value`` as a finite float vector of shape ``(size,)``, or ValueError."""
    array = _finite_array(name, value, 1)
    if array.shape != (size,):
        raise ValueError(f"{name} must have shape ({size},), got {array.shape}")
    return array


def _positive(name: str, value: float) -> float:
    """``value`` as a finite float > 0, or ValueError."""
    number = float(value)
    if not math.isfinite(number) or number <= 0.0:
        raise ValueError(f"{name} must be a finite number > 0, got {value!r}")
    return number


def _frozen(array: np.ndarray) -> np.ndarray:
    array.setflags(write=False)
    return array


def _times(value: object, min_samples: int = 2) -> np.ndarray:
    """Validated sample times (n,) in s: finite and strictly increasing."""
    times = _finite_array("times", value, 1)
    if times.size < min_samples:
        raise ValueError(f"times must have at least {min_samples} samples, got {times.size}")
    steps = np.diff(times)
    if np.any(steps <= 0.0):
        k = int(np.argmax(steps <= 0.0)) + 1
        raise ValueError(f"times must be strictly increasing, times[{k}] = {times[k]} <= {times[k - 1]}")
    return times


def _samples(times: np.ndarray, value: object, name: str) -> np.ndarray:
    """Validated per-sample values (n, d) matching ``times``."""
    array = _finite_array(name, value, 2)
    if array.shape[0] != times.size or array.shape[1] < 1:
        raise ValueError(
            f"{name} must have shape (n, d) with n = len(times) = {times.size}, got {array.shape}"
        )
    return array


@dataclass(frozen=True, eq=False)
class Trajectory:
    """A sampled trajectory.

    Attributes:
        times: (n,) sample times in s, strictly increasing.
        positions: (n, d) positions; metres (world frame) for x, y, z, radians for Euler angles.
        velocities: (n, d) time derivatives of ``positions`` (m/s, rad/s), or None if unknown.
    """

    times: np.ndarray
    positions: np.ndarray
    velocities: np.ndarray | None = None

    def __post_init__(self) -> None:
        times = _times(self.times, min_samples=1)
        object.__setattr__(self, "times", _frozen(times))
        object.__setattr__(self, "positions", _frozen(_samples(times, self.positions, "positions")))
        if self.velocities is not None:
            velocities = _samples(times, self.velocities, "velocities")
            if velocities.shape != self.positions.shape:
                raise ValueError(f"velocities must have shape {self.positions.shape}, got {velocities.shape}")
            object.__setattr__(self, "velocities", _frozen(velocities))

    @property
    def duration(self) -> float:
        """Time from the first to the last sample, s."""
        return float(self.times[-1] - self.times[0])


@dataclass(frozen=True, eq=False)
class DMPParameters:
    """A learned DMP (Eq. 1–3), one transformation system per dimension sharing one canonical system.

    Attributes:
        weights: (d, N) basis weights w_i per dimension (Eq. 2).
        centres: (N,) basis centres c_i in phase units (Eq. 3), decreasing from x0.
        widths: (N,) basis widths σ_i in phase units (Eq. 3).
        alpha_y: gain α_y (Eq. 1).
        beta_y: gain β_y (Eq. 1).
        alpha_x: canonical-system decay α_x (Eq. 2).
        x0: initial phase.
        tau: time constant τ in s (Eq. 1, 2); the demonstration's duration.
        y0: (d,) start of the demonstration.
        goal: (d,) goal g of the demonstration (its last sample).
        goal_scaled: (d,) bool; True where the forcing term is scaled by ``g − y0`` (Eq. 2), False
            where the demonstration had ``g ≈ y0`` and the unscaled fallback is used (module doc).
    """

    weights: np.ndarray
    centres: np.ndarray
    widths: np.ndarray
    alpha_y: float
    beta_y: float
    alpha_x: float
    x0: float
    tau: float
    y0: np.ndarray
    goal: np.ndarray
    goal_scaled: np.ndarray

    def __post_init__(self) -> None:
        weights = _finite_array("weights", self.weights, 2)
        n_dims, n_basis = weights.shape
        if n_dims < 1 or n_basis < 2:
            raise ValueError(f"weights must have shape (d, N) with d >= 1 and N >= 2, got {weights.shape}")
        widths = _vector("widths", self.widths, n_basis)
        if np.any(widths <= 0.0):
            raise ValueError("widths must all be > 0")
        goal_scaled = np.array(self.goal_scaled)
        if goal_scaled.dtype != bool or goal_scaled.shape != (n_dims,):
            raise ValueError(
                f"goal_scaled must be a bool array of shape ({n_dims},), got {goal_scaled.shape}"
            )
        for name in ("alpha_y", "beta_y", "alpha_x", "x0", "tau"):
            object.__setattr__(self, name, _positive(name, getattr(self, name)))
        object.__setattr__(self, "weights", _frozen(weights))
        object.__setattr__(self, "centres", _frozen(_vector("centres", self.centres, n_basis)))
        object.__setattr__(self, "widths", _frozen(widths))
        object.__setattr__(self, "y0", _frozen(_vector("y0", self.y0, n_dims)))
        object.__setattr__(self, "goal", _frozen(_vector("goal", self.goal, n_dims)))
        object.__setattr__(self, "goal_scaled", _frozen(goal_scaled))

    @property
    def n_dims(self) -> int:
        """Number of dimensions d."""
        return self.weights.shape[0]

    @property
    def n_basis(self) -> int:
        """Number of basis functions N."""
        return self.weights.shape[1]

    def displaced_goal(self, y0: np.ndarray) -> np.ndarray:
        """Goal for a task without a target object (moving, folding; §III-E): the new start plus the
        demonstration's displacement ``goal − y0``. Returns a (d,) array."""
        return _vector("y0", y0, self.n_dims) + (self.goal - self.y0)

    def phase(self, t: np.ndarray | float, tau: float | None = None) -> np.ndarray:
        """Canonical-system phase x(t) = x0 exp(−α_x t / τ), the solution of τ ẋ = −α_x x (Eq. 2).

        Args:
            t: time(s) since the start of the movement, s; any shape.
            tau: time constant in s, default :attr:`tau`.

        Returns:
            Phase values, same shape as ``t``.
        """
        return self.x0 * np.exp(
            -self.alpha_x * np.asarray(t, dtype=float) / (self.tau if tau is None else tau)
        )

    def forcing(self, x: np.ndarray, y0: np.ndarray, goal: np.ndarray) -> np.ndarray:
        """Forcing term f of Eq. 2 for a movement from ``y0`` to ``goal``.

        The normalised basis weights Ψ_i / Σ_j Ψ_j are computed as a softmax of the log-Gaussians, so
        they stay defined when every Ψ_i underflows (phases far below the last centre).

        Args:
            x: (m,) phase values.
            y0: (d,) start of the movement.
            goal: (d,) goal of the movement.

        Returns:
            (m, d) forcing term, in units of position (f enters Eq. 1 as ``τ² ÿ``).
        """
        x = np.atleast_1d(np.asarray(x, dtype=float))
        logits = -((x[:, None] - self.centres[None, :]) ** 2) / (2.0 * self.widths**2)
        psi = np.exp(logits - logits.max(axis=1, keepdims=True))
        mixture = (psi @ self.weights.T) / psi.sum(axis=1, keepdims=True)
        return mixture * x[:, None] * self._scale(y0, goal)[None, :]

    def _scale(self, y0: np.ndarray, goal: np.ndarray) -> np.ndarray:
        """(d,) factor multiplying the forcing term: ``g − y0`` where scaled, 1 elsewhere."""
        return np.where(self.goal_scaled, goal - y0, 1.0)

    def unforced(self, dims: np.ndarray) -> DMPParameters:
        """The same demonstration without a forcing term in the dimensions ``dims`` ((d,) bool): there a
        rollout is the plain spring-damper transition of Eq. 1 from its start to its goal, a straight
        line (the demonstrated excursion of that dimension is dropped)."""
        dims = np.asarray(dims, dtype=bool)
        return dataclasses.replace(self, weights=np.where(dims[:, None], 0.0, self.weights))

    def unscaled(self, dims: np.ndarray) -> DMPParameters:
        """The same demonstration with the forcing term of the dimensions ``dims`` ((d,) bool) unscaled:
        weights multiplied by the demonstration's ``g − y0`` so that the learned forcing is unchanged, and
        no longer rescaled by a new ``g − y0``.

        Eq. 2's scaling mirrors the movement when the new ``g − y0`` has the opposite sign of the
        demonstrated one and stretches it without bound when the ratio is large (Ijspeert et al. 2013,
        §2.1.5; Pastor et al. 2009). A rollout can switch such dimensions to the unscaled form, which
        keeps the demonstrated shape in absolute units on top of the transition to the new goal.
        """
        dims = np.asarray(dims, dtype=bool) & self.goal_scaled
        weights = np.where(dims[:, None], self.weights * (self.goal - self.y0)[:, None], self.weights)
        return dataclasses.replace(self, weights=weights, goal_scaled=self.goal_scaled & ~dims)


def default_basis(
    n_basis: int = N_BASIS, alpha_x: float = ALPHA_X, x0: float = X0
) -> tuple[np.ndarray, np.ndarray]:
    """Centres and widths of the Gaussian basis of Eq. 3.

    The paper does not give them. Centres are the phases reached at N equally spaced times over the
    demonstration, ``c_i = x0 exp(−α_x i / (N − 1))``, so that each basis covers an equal share of the
    movement's duration (a common choice in implementations of Ijspeert et al. 2013). Each width σ_i
    is half the distance to the next centre, so neighbours overlap at Ψ = exp(−2) ≈ 0.14 (compared with
    σ_i = the distance in BENCHMARKS.md, DMP).

    Returns:
        (centres (N,), widths (N,)), both in phase units.
    """
    if n_basis < 2:
        raise ValueError(f"n_basis must be >= 2, got {n_basis}")
    centres = x0 * np.exp(-alpha_x * np.linspace(0.0, 1.0, n_basis))
    gaps = -np.diff(centres)
    widths = np.append(gaps, gaps[-1]) / 2.0
    return centres, widths


def learn_dmp(
    times: np.ndarray,
    positions: np.ndarray,
    *,
    n_basis: int = N_BASIS,
    alpha_y: float = ALPHA_Y,
    beta_y: float | None = None,
    alpha_x: float = ALPHA_X,
    x0: float = X0,
) -> DMPParameters:
    """Learn a DMP from one demonstration by locally weighted regression (§III-D).

    Velocities and accelerations are second-order finite differences of ``positions``. The target
    forcing term is Eq. 1 solved for f, ``f_t = τ² ÿ_t − α_y (β_y (g − y_t) − τ ẏ_t)``, with τ the
    demonstration's duration, g its last and y0 its first sample. Each weight is the locally weighted
    regression of Ijspeert et al. 2013 (one weighted least-squares fit per basis),
    ``w_i = Σ_t Ψ_i(x_t) s_t f_t / Σ_t Ψ_i(x_t) s_t²`` with ``s_t = x_t (g − y0)`` (or ``s_t = x_t`` in
    the unscaled fallback, see the module doc). A
    basis that no sample reaches (demonstrations much sparser than N samples) gets weight 0.

    Args:
        times: (n,) sample times in s, strictly increasing, n >= 3.
        positions: (n, d) end-effector positions (m) and optionally unwrapped Euler angles (rad).
        n_basis: number of basis functions N.
        alpha_y: gain α_y.
        beta_y: gain β_y, default α_y / 4.
        alpha_x: canonical-system decay α_x.
        x0: initial phase.

    Returns:
        The learned parameters.

    Raises:
        ValueError: on wrong shapes, NaN/inf, non-increasing times or fewer than 3 samples.
    """
    times = _times(times, min_samples=3)
    positions = _samples(times, positions, "positions")
    alpha_y = _positive("alpha_y", alpha_y)
    beta_y = alpha_y / 4.0 if beta_y is None else _positive("beta_y", beta_y)
    alpha_x = _positive("alpha_x", alpha_x)
    x0 = _positive("x0", x0)
    t = times - times[0]
    tau = float(t[-1])
    y0, goal = positions[0], positions[-1]
    velocities = np.gradient(positions, t, axis=0, edge_order=2)
    accelerations = np.gradient(velocities, t, axis=0, edge_order=2)
    target = tau**2 * accelerations - alpha_y * (beta_y * (goal - positions) - tau * velocities)

    excursion = np.max(np.abs(positions - y0), axis=0)
    goal_scaled = np.abs(goal - y0) > _GOAL_TOLERANCE * excursion
    scale = np.where(goal_scaled, goal - y0, 1.0)

    centres, widths = default_basis(n_basis, alpha_x, x0)
    x = x0 * np.exp(-alpha_x * t / tau)
    psi = np.exp(-((x[:, None] - centres[None, :]) ** 2) / (2.0 * widths**2))
    s = x[:, None] * scale[None, :]
    numerator = psi.T @ (s * target)
    denominator = psi.T @ (s**2)
    weights = np.divide(numerator, denominator, out=np.zeros_like(numerator), where=denominator > 0.0)
    return DMPParameters(
        weights=weights.T,
        centres=centres,
        widths=widths,
        alpha_y=alpha_y,
        beta_y=beta_y,
        alpha_x=alpha_x,
        x0=x0,
        tau=tau,
        y0=y0,
        goal=goal,
        goal_scaled=goal_scaled,
    )


def _expm(matrix: np.ndarray) -> np.ndarray:
    """Matrix exponential of a small square matrix by scaling and squaring a Taylor series.

    Kept in numpy (scipy is an optional dependency of the package); exact to rounding for the 3 × 3
    matrices of :func:`_discretise`, including the defective (critically damped) case that an
    eigen-decomposition cannot handle.
    """
    norm = float(np.max(np.sum(np.abs(matrix), axis=1)))
    squarings = max(0, math.ceil(math.log2(norm / 0.5))) if norm > 0.5 else 0
    scaled = matrix / 2.0**squarings
    result = np.eye(matrix.shape[0])
    term = np.eye(matrix.shape[0])
    for k in range(1, 20):
        term = term @ scaled / k
        result = result + term
    for _ in range(squarings):
        result = result @ result
    return result


def _discretise(stiffness: float, damping: float, h: float) -> tuple[np.ndarray, np.ndarray]:
    """Exact zero-order-hold discretisation of ``ë = −K e − D ė + u`` over a step of ``h`` s.

    Returns ``(Φ (2, 2), Γ (2,))`` with ``[e, ė](t + h) = Φ [e, ė](t) + Γ u`` for ``u`` held constant.
    """
    augmented = np.zeros((3, 3))
    augmented[0, 1] = 1.0
    augmented[1, 0] = -stiffness
    augmented[1, 1] = -damping
    augmented[1, 2] = 1.0
    transition = _expm(augmented * h)
    return transition[:2, :2], transition[:2, 2]


def _step_matrices(stiffness: float, damping: float, h: float, n_sub: int) -> tuple[np.ndarray, np.ndarray]:
    """:func:`_discretise`'s step applied ``n_sub`` times, in closed form.

    Returns ``(Φⁿ (2, 2), W (2, n))`` with ``[e, ė](t + n h) = Φⁿ [e, ė](t) + W u`` for the inputs
    ``u`` (n, d) held constant over each of the ``n`` sub-steps: ``W[:, k] = Φ^(n−1−k) Γ``. One product
    replaces a loop of ``n`` small array operations per control step.
    """
    transition, gain = _discretise(stiffness, damping, h)
    gains = np.empty((2, n_sub))
    power = np.eye(2)
    for k in range(n_sub - 1, -1, -1):
        gains[:, k] = power @ gain
        power = transition @ power
    return power, gains


@dataclass(frozen=True, eq=False)
class RolloutState:
    """Snapshot of a :class:`DMPRollout`, restorable with :meth:`DMPRollout.restore`.

    Attributes:
        time: time since the start of the rollout, s.
        position: (d,) position y.
        velocity: (d,) velocity ẏ.
        goal: (d,) goal g in force at that time.
    """

    time: float
    position: np.ndarray
    velocity: np.ndarray
    goal: np.ndarray


class DMPRollout:
    """Step-by-step integration of a learned DMP from a new start to a new goal (§III-E).

    The canonical phase is the closed-form solution of ``τ ẋ = −α_x x`` at the current time. The
    transformation system (Eq. 1) is linear in ``(y − g, ẏ)`` apart from the forcing term, so each
    sub-step advances it with its exact zero-order-hold discretisation, holding f at the phase of the
    sub-step's midpoint (second-order accurate in the sub-step, stable for any step length). Steps
    longer than ``max_substep`` are split into equal sub-steps. The discretisation of the last
    sub-step length is cached, so constant steps cost no matrix exponential.

    Goal changes (:meth:`set_goal`) keep the phase running and the start ``y0``, so the remaining
    movement is re-planned from the current state towards the new goal with the forcing term scaled
    by ``g_new − y0``, as Alg. 2 does after a collision. :meth:`back_up` returns to the state of a
    given number of steps earlier (Alg. 2 goes back 10 trajectory points); :meth:`state` and
    :meth:`restore` save and restore arbitrary states.
    """

    def __init__(
        self,
        params: DMPParameters,
        y0: np.ndarray,
        goal: np.ndarray,
        *,
        tau: float | None = None,
        velocity: np.ndarray | None = None,
        max_substep: float | None = None,
        history: int = BACKUP_POINTS,
    ) -> None:
        """Start a rollout at time 0.

        Args:
            params: the learned DMP.
            y0: (d,) start position (m, rad); also the ``y0`` of Eq. 2.
            goal: (d,) goal position (m, rad).
            tau: time constant in s, default ``params.tau`` (the demonstration's duration); larger
                is slower.
            velocity: (d,) initial velocity, default zero.
            max_substep: longest integration sub-step in s, default ``tau / 500``.
            history: number of past states kept for :meth:`back_up`.
        """
        self.params = params
        d = params.n_dims
        self._y0 = _frozen(_vector("y0", y0, d))
        self._goal = _vector("goal", goal, d)
        self.tau = params.tau if tau is None else _positive("tau", tau)
        self.max_substep = self.tau / 500.0 if max_substep is None else _positive("max_substep", max_substep)
        if history < 0:
            raise ValueError(f"history must be >= 0, got {history}")
        self._time = 0.0
        self._position = self._y0.copy()
        self._velocity = np.zeros(d) if velocity is None else _vector("velocity", velocity, d)
        self._history: deque[RolloutState] = deque(maxlen=history)
        self._stiffness = params.alpha_y * params.beta_y / self.tau**2
        self._damping = params.alpha_y / self.tau
        self._discretisation: tuple[float, int, np.ndarray, np.ndarray] | None = None

    @property
    def time(self) -> float:
        """Time since the start of the rollout, s."""
        return self._time

    @property
    def progress(self) -> float:
        """Time as a fraction of τ (1 at the demonstration's end; keeps growing afterwards)."""
        return self._time / self.tau

    @property
    def phase(self) -> float:
        """Canonical-system phase x at the current time."""
        return float(self.params.phase(self._time, self.tau))

    @property
    def y0(self) -> np.ndarray:
        """(d,) start of the rollout."""
        return self._y0

    @property
    def goal(self) -> np.ndarray:
        """(d,) current goal (a copy)."""
        return self._goal.copy()

    @property
    def position(self) -> np.ndarray:
        """(d,) current position (a copy)."""
        return self._position.copy()

    @property
    def velocity(self) -> np.ndarray:
        """(d,) current velocity (a copy)."""
        return self._velocity.copy()

    @property
    def kept(self) -> int:
        """Number of past steps :meth:`back_up` can return to."""
        return len(self._history)

    def set_goal(self, goal: np.ndarray) -> None:
        """Change the goal g from now on; the phase, start and current state are kept."""
        self._goal = _vector("goal", goal, self.params.n_dims)

    def state(self) -> RolloutState:
        """Snapshot of the current time, position, velocity and goal."""
        return RolloutState(self._time, self._position.copy(), self._velocity.copy(), self._goal.copy())

    def restore(self, state: RolloutState) -> None:
        """Continue from ``state``; the continuation is identical to the one after it was taken.

        The back-up history is cleared.
        """
        d = self.params.n_dims
        self._time = float(state.time)
        self._position = _vector("state.position", state.position, d)
        self._velocity = _vector("state.velocity", state.velocity, d)
        self._goal = _vector("state.goal", state.goal, d)
        self._history.clear()

    def back_up(self, n_points: int = BACKUP_POINTS) -> RolloutState:
        """Return to the state of ``n_points`` steps ago (Alg. 2, line 10) and return that state.

        Raises:
            ValueError: if fewer than ``n_points`` past steps are kept.
        """
        if not 1 <= n_points <= len(self._history):
            raise ValueError(f"cannot back up {n_points} points, {len(self._history)} are kept")
        for _ in range(n_points - 1):
            self._history.pop()
        state = self._history.pop()
        self._time = state.time
        self._position = state.position.copy()
        self._velocity = state.velocity.copy()
        self._goal = state.goal.copy()
        return state

    def step(self, dt: float) -> tuple[np.ndarray, np.ndarray]:
        """Advance by ``dt`` s and return copies of the new (position (d,), velocity (d,))."""
        dt = _positive("dt", dt)
        if self._history.maxlen:
            self._history.append(self.state())
        n_sub = max(1, math.ceil(dt / self.max_substep - 1e-9))
        h = dt / n_sub
        if self._discretisation is None or self._discretisation[:2] != (h, n_sub):
            self._discretisation = (h, n_sub, *_step_matrices(self._stiffness, self._damping, h, n_sub))
        _, _, transition, gains = self._discretisation
        midpoints = self._time + h * (np.arange(n_sub) + 0.5)
        inputs = (
            self.params.forcing(self.params.phase(midpoints, self.tau), self._y0, self._goal) / self.tau**2
        )
        error = self._position - self._goal
        forced = gains @ inputs
        error, velocity = (
            transition[0, 0] * error + transition[0, 1] * self._velocity + forced[0],
            transition[1, 0] * error + transition[1, 1] * self._velocity + forced[1],
        )
        self._time += dt
        self._position = error + self._goal
        self._velocity = velocity
        return self._position.copy(), self._velocity.copy()


def rollout(
    params: DMPParameters,
    y0: np.ndarray,
    goal: np.ndarray,
    *,
    duration: float | None = None,
    n_steps: int = 1000,
    tau: float | None = None,
) -> Trajectory:
    """Integrate the DMP from ``y0`` to ``goal`` over ``duration`` s in ``n_steps`` equal steps.

    Args:
        params: the learned DMP.
        y0: (d,) start (m, rad).
        goal: (d,) goal (m, rad).
        duration: s, default the rollout's τ (``tau`` or ``params.tau``).
        n_steps: number of steps; the trajectory has ``n_steps + 1`` samples including the start.
        tau: time constant in s, default ``params.tau``.

    Returns:
        Times from 0 s, positions and velocities.
    """
    if n_steps < 1:
        raise ValueError(f"n_steps must be >= 1, got {n_steps}")
    runner = DMPRollout(params, y0, goal, tau=tau, history=0)
    duration = runner.tau if duration is None else _positive("duration", duration)
    dt = duration / n_steps
    positions = np.empty((n_steps + 1, params.n_dims))
    velocities = np.empty_like(positions)
    positions[0], velocities[0] = runner.position, runner.velocity
    for k in range(1, n_steps + 1):
        positions[k], velocities[k] = runner.step(dt)
    return Trajectory(np.arange(n_steps + 1) * dt, positions, velocities)


def save_parameters(params: DMPParameters, path: str | Path) -> tuple[Path, Path]:
    """Write ``params`` as ``<path>.json`` (format version, scalars) and ``<path>.npz`` (arrays).

    Any suffix of ``path`` is replaced; missing parent directories are created. Floats are written
    exactly (JSON uses their shortest round-trip representation; the NPZ holds raw float64).

    Returns:
        (JSON path, NPZ path).
    """
    base = Path(path)
    json_path, npz_path = base.with_suffix(".json"), base.with_suffix(".npz")
    json_path.parent.mkdir(parents=True, exist_ok=True)
    meta = {
        "kind": _FORMAT_KIND,
        "format_version": FORMAT_VERSION,
        "arrays": npz_path.name,
        "n_dims": params.n_dims,
        "n_basis": params.n_basis,
        "alpha_y": params.alpha_y,
        "beta_y": params.beta_y,
        "alpha_x": params.alpha_x,
        "x0": params.x0,
        "tau": params.tau,
    }
    np.savez(
        npz_path,
        weights=params.weights,
        centres=params.centres,
        widths=params.widths,
        y0=params.y0,
        goal=params.goal,
        goal_scaled=params.goal_scaled,
    )
    json_path.write_text(json.dumps(meta, indent=2) + "\n")
    return json_path, npz_path


def load_parameters(path: str | Path) -> DMPParameters:
    """Read parameters written by :func:`save_parameters` (``path`` with or without a suffix).

    Raises:
        ValueError: if the files are not DMP parameters of a supported format version.
    """
    json_path = Path(path).with_suffix(".json")
    try:
        meta = json.loads(json_path.read_text())
    except json.JSONDecodeError as error:
        raise ValueError(f"{json_path} is not valid JSON: {error}") from None
    if not isinstance(meta, dict) or meta.get("kind") != _FORMAT_KIND:
        raise ValueError(f"{json_path} does not describe DMP parameters (kind != {_FORMAT_KIND!r})")
    if meta.get("format_version") != FORMAT_VERSION:
        raise ValueError(
            f"{json_path} has format version {meta.get('format_version')!r}, expected {FORMAT_VERSION}"
        )
    missing = sorted(_META_FIELDS - meta.keys())
    if missing:
        raise ValueError(f"{json_path} lacks the field(s) {', '.join(missing)}")
    with np.load(json_path.with_name(Path(meta["arrays"]).name), allow_pickle=False) as arrays:
        missing = sorted(_ARRAY_FIELDS - set(arrays.files))
        if missing:
            raise ValueError(f"{json_path}: the arrays file lacks {', '.join(missing)}")
        params = DMPParameters(
            weights=arrays["weights"],
            centres=arrays["centres"],
            widths=arrays["widths"],
            alpha_y=meta["alpha_y"],
            beta_y=meta["beta_y"],
            alpha_x=meta["alpha_x"],
            x0=meta["x0"],
            tau=meta["tau"],
            y0=arrays["y0"],
            goal=arrays["goal"],
            goal_scaled=arrays["goal_scaled"],
        )
    if (params.n_dims, params.n_basis) != (meta["n_dims"], meta["n_basis"]):
        raise ValueError(f"{json_path}: arrays have shape {params.weights.shape}, metadata says otherwise")
    return params


@dataclass(frozen=True)
class GripperEvent:
    """A change of the gripper command during a primitive task, kept as a timed event.

    Attributes:
        fraction: when the command takes effect, as a fraction of the movement's duration τ
            (0 = start, 1 = end); the canonical phase at that moment is ``x0 exp(−α_x · fraction)``.
        command: the gripper command from then on (e.g. 0 open, 1 closed, or an opening width in m).
    """

    fraction: float
    command: float

    def time(self, duration: float, start_time: float = 0.0) -> float:
        """Time of the event in s on a movement of ``duration`` s starting at ``start_time``."""
        return start_time + self.fraction * duration


def extract_gripper_events(
    times: np.ndarray, commands: np.ndarray, *, tolerance: float = 1e-9
) -> tuple[GripperEvent, ...]:
    """Gripper events of a demonstration: the initial command, then one event per change.

    Args:
        times: (n,) sample times in s, strictly increasing (the demonstration's time base).
        commands: (n,) gripper command at each sample.
        tolerance: changes no larger than this are ignored.

    Returns:
        Events ordered by fraction; the first is at fraction 0 with ``commands[0]``. A change between
        samples k − 1 and k is placed at sample k.
    """
    times = _times(times)
    commands = _finite_array("commands", commands, 1)
    if commands.shape != times.shape:
        raise ValueError(f"commands must have shape {times.shape} like times, got {commands.shape}")
    fractions = (times - times[0]) / (times[-1] - times[0])
    events = [GripperEvent(0.0, float(commands[0]))]
    current = commands[0]
    for k in range(1, commands.size):
        if abs(commands[k] - current) > tolerance:
            current = commands[k]
            events.append(GripperEvent(float(fractions[k]), float(current)))
    return tuple(events)


def gripper_schedule(
    events: tuple[GripperEvent, ...] | list[GripperEvent], duration: float, start_time: float = 0.0
) -> list[tuple[float, float]]:
    """Map events onto a rollout's time scale: ``[(time s, command), ...]`` for a movement of
    ``duration`` s (usually the rollout's τ) starting at ``start_time`` s."""
    duration = _positive("duration", duration)
    return [(event.time(duration, start_time), event.command) for event in events]


def gripper_command_at(events: tuple[GripperEvent, ...] | list[GripperEvent], fraction: float) -> float:
    """The command in force at ``fraction`` of the movement (e.g. :attr:`DMPRollout.progress`).

    Before the first event the first event's command applies.
    """
    if not events:
        raise ValueError("events must not be empty")
    command = events[0].command
    for event in sorted(events, key=lambda e: e.fraction):
        if event.fraction <= fraction:
            command = event.command
    return command
