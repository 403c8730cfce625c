"""How uncertain parameters make the answer uncertain: first-order propagation, checked by Monte Carlo.

**Uncertain parameters** (:mod:`esba.calibration.sigmas`: :class:`SigmaSpec`, :func:`parse_sigma`, :func:`load_sigmas`,
re-exported here): any
scene parameter of :mod:`esba.analysis.sensitivity` with a standard deviation in its scene-file unit
(``E=0.05``: sigma 0.05 MPa), relative to its value (``E=10%``), or a tolerance ``±t`` (also
``+-t``, ``±10%``): uniform on [-t, t], so sigma = t / sqrt(3) (the GUM's rectangular
distribution). On the command line ``--sigma E=0.05 --sigma r2=±0.1``; in a scene file a table

    [uncertainty]
    E = "10%"
    r2 = 0.1
    rho = "±2"

The parameters are taken as independent.

**First order** (:func:`propagate`): with the sensitivities S = dy/dp of :mod:`esba.analysis.sensitivity`
for y = (theta, tip x, tip y, theta_TOL), Cov(y) = S diag(sigma^2) S^T: the standard deviation of
the tip and of the total angle, each parameter's share of the variance, and the tip's covariance
ellipse (95 % by default). It is only as good as the linearisation: near a fold (where the
sensitivities are not defined) it gives no numbers, and when 3 sigma of a parameter reaches the
fold's estimated distance (:attr:`esba.analysis.sensitivity.Sensitivities.fold_distance`) it says that
the first-order answer cannot be trusted.

**Monte Carlo** (:func:`monte_carlo`): ``samples`` parameter sets drawn up front from one seeded
generator (normal, or uniform for tolerances), then solved in independent chunks on the batch
path (:mod:`esba.statics.batch`: compiled Newton continuation along each sample's own load path, IPOPT
for the few it cannot do). Each chunk is :func:`solve_samples`, a pure function of (base scene,
parameter names, parameter arrays) returning arrays, so the chunks can run anywhere (in this
process, or on Dask workers: ``runner``, :mod:`esba.studies.distributed`) and the result is the same
whatever the chunking; :mod:`esba.studies.monte_carlo` streams the samples to a file and resumes it. Samples the scene's rules do not
allow (e.g. r2 + d >= r1) and samples that end on no stable equilibrium are counted and left out.
:func:`compare` sets the two side by side and gives a verdict.

Examples
--------
>>> from esba.model.scene import MAIN_JOB
>>> from esba.statics.equilibrium import solve
>>> r = solve(MAIN_JOB)
>>> u = propagate(r, resolve_sigmas(MAIN_JOB, [parse_sigma("E=10%")]))
>>> u.status, round(u.std_total_angle_deg, 3), [round(v, 3) for v in u.std_tip_mm]
('ok', 5.495, [0.999, 7.376])
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable, ClassVar, NamedTuple, Sequence

import numpy as np

from esba.analysis.sensitivity import SensitivityOptions, sensitivities, with_parameters
from esba.infra import checks, jsonsafe
from esba.infra.report import Report
from esba.model.scene import Scene, SceneError
from esba.statics.batch import BatchOptions, compiler, prepare, solve_arrays
from esba.statics.batch_options import AUTO_COMPILE_MAX_N, MAX_BATCH_BYTES
from esba.statics.equilibrium import Equilibrium

from .sigmas import (
    Sigma,
    SigmaSpec,
    UncertaintyError,
    _checked_sigmas,
    load_sigmas,
    parse_sigma,
    resolve_sigmas,
    sigmas_from_table,
)

__all__ = [
    "UncertaintyError",
    "Ellipse",
    "SigmaSpec",
    "Sigma",
    "Propagation",
    "MonteCarloOptions",
    "MonteCarlo",
    "Agreement",
    "parse_sigma",
    "sigmas_from_table",
    "load_sigmas",
    "resolve_sigmas",
    "propagate",
    "draw_samples",
    "solve_samples",
    "monte_carlo",
    "compare",
    "ellipse",
]

#: The most Monte Carlo samples one run may draw (they are all held in memory).
MAX_SAMPLES = 1_000_000

#: The most samples of a 3-D Monte Carlo (:mod:`esba.calibration.uncertainty3d`): each is a load
#: history of damped Newton solves in Python, about 10 ms at n = 3 (the 3-D sweep's bound too).
MAX_SAMPLES_3D = 100_000

#: Outputs reported by propagation and Monte Carlo, with their units.
OUTPUTS = (("tip_x", "mm"), ("tip_y", "mm"), ("total_angle", "deg"))


# ---------------------------------------------------------------------------------------------
# first order


class Ellipse(NamedTuple):
    """A covariance ellipse (:func:`ellipse`): a named tuple ``(semi_axes, angle)``, unpacked as before.

    Attributes
    ----------
    semi_axes : ndarray
        The semi-axes, largest first, in the covariance's unit (mm for a tip).
    angle : float
        The major axis's angle from x toward y, rad.
    """

    semi_axes: np.ndarray
    angle: float

    @property
    def angle_deg(self) -> float:
        """The major axis's angle from x toward y, degrees."""
        return math.degrees(self.angle)

    def __repr__(self) -> str:
        a, b = (float(v) for v in self.semi_axes)
        return f"Ellipse(semi_axes=({a:.4g}, {b:.4g}) mm, angle_deg={self.angle_deg:.2f})"


def ellipse(cov: np.ndarray, level: float = 0.95) -> Ellipse:
    """Semi-axes (mm, largest first) and the angle of the major axis (rad, from x toward y) of
    the ``level`` ellipse of a 2x2 Gaussian covariance: an :class:`Ellipse`, which unpacks as
    ``(semi_axes, angle)``.

    >>> e = ellipse(np.diag([4.0, 1.0]))
    >>> e
    Ellipse(semi_axes=(4.895, 2.448) mm, angle_deg=0.00)
    >>> axes, angle = e
    >>> [round(float(a), 4) for a in axes], round(angle, 6)
    ([4.8955, 2.4477], 0.0)
    """
    if isinstance(level, bool) or not isinstance(level, (int, float)) or not 0.0 < level < 1.0:
        raise UncertaintyError(f"level={checks.quote(level)}: expected 0 < level < 1")
    cov = checks.covariance("cov", cov, 2, UncertaintyError)
    k = math.sqrt(-2.0 * math.log(1.0 - level))
    w, v = np.linalg.eigh(cov)
    w = np.maximum(w, 0.0)[::-1]  # round-off below 0 (check_covariance refused more)
    v = v[:, ::-1]
    return Ellipse(k * np.sqrt(w), float(math.atan2(v[1, 0], v[0, 0]) % math.pi))


@dataclass(frozen=True, eq=False, repr=False)
class Propagation(Report):
    """First-order uncertainty of an equilibrium.

    Attributes
    ----------
    sigmas : tuple of Sigma
    status : str
        ``ok``; ``near_fold`` (no sensitivities: no numbers); ``beyond_linear_range`` (numbers
        given, but 3 sigma of some parameter reaches the fold's estimated distance: do not trust
        them); ``not_stable`` (no stable equilibrium: no numbers); ``overflow`` (the sigmas are so
        large that the covariance is not a finite number: no numbers).
    message : str
    cov_theta : ndarray, shape (n, n)
        rad^2.
    cov_tip : ndarray, shape (2, 2)
        mm^2.
    var_total : float
        Variance of theta_TOL, rad^2.
    shares : dict
        Each parameter's share of the variance of tip x, tip y and the total angle (sums to 1).
    nominal_tip : ndarray
        The solved tip, mm.
    nominal_total_deg : float
    """

    sigmas: tuple[Sigma, ...]
    status: str
    message: str
    cov_theta: np.ndarray
    cov_tip: np.ndarray
    var_total: float
    shares: dict
    nominal_tip: np.ndarray
    nominal_total_deg: float

    _plotter = "esba.figures.results:draw_propagation"
    #: The outputs (name, unit) whose standard deviations :meth:`std` gives.
    outputs: ClassVar[tuple[tuple[str, str], ...]] = OUTPUTS

    def nominal(self, output: str) -> float:
        """The solved value of ``tip_x``, ``tip_y`` (mm) or ``total_angle`` (deg)."""
        return {"tip_x": float(self.nominal_tip[0]), "tip_y": float(self.nominal_tip[1]), "total_angle": float(self.nominal_total_deg)}[output]

    def headline(self) -> str:
        """One line: the status and the standard deviations of the total angle and the tip."""
        if not self.has_numbers:
            return f"{self.status}: {self.message}"
        x, y = self.std_tip_mm
        return f"{self.status}: std total angle {self.std_total_angle_deg:.4g} deg, tip x, y {x:.4g}, {y:.4g} mm (first order)"

    def summary(self) -> str:
        """The uncertainty lines ``esba solve --sigma ...`` prints."""
        from esba.statics.text import uncertainty_rows

        return "\n".join(f"{k:>12}: {v}" for k, v in uncertainty_rows({"uncertainty": self.to_dict()}))

    @property
    def ok(self) -> bool:
        """The first-order numbers exist and are within the linear range."""
        return self.status == "ok"

    @property
    def has_numbers(self) -> bool:
        """Numbers were computed (``ok`` or ``beyond_linear_range``)."""
        return self.status in ("ok", "beyond_linear_range")

    @property
    def std_tip_mm(self) -> list[float]:
        """Standard deviations of tip x and y, mm."""
        return [float(v) for v in np.sqrt(np.maximum(np.diag(self.cov_tip), 0.0))]

    @property
    def std_total_angle_deg(self) -> float:
        """Standard deviation of the total angle, degrees."""
        return math.degrees(math.sqrt(max(self.var_total, 0.0)))

    def std(self, output: str) -> float:
        """Standard deviation of ``tip_x``, ``tip_y`` (mm) or ``total_angle`` (deg)."""
        return {"tip_x": self.std_tip_mm[0], "tip_y": self.std_tip_mm[1], "total_angle": self.std_total_angle_deg}[output]

    def ellipse(self, level: float = 0.95) -> Ellipse:
        """The tip's ``level`` covariance ellipse: semi-axes (mm) and angle (rad, from x toward y)."""
        return ellipse(self.cov_tip, level)

    def to_dict(self) -> dict:
        """JSON-ready form (None for every number when there are none)."""
        num = self.has_numbers
        axes, angle = self.ellipse() if num else (None, None)
        return jsonsafe.clean({
            "status": self.status,
            "message": self.message,
            "sigmas": [s.to_dict() for s in self.sigmas],
            "std_tip_mm": self.std_tip_mm if num else None,
            "std_total_angle_deg": self.std_total_angle_deg if num else None,
            "cov_tip_mm2": self.cov_tip.tolist() if num else None,
            "std_theta_deg": [math.degrees(math.sqrt(max(v, 0.0))) for v in np.diag(self.cov_theta)] if num else None,
            "tip_ellipse_95": {"semi_axes_mm": axes, "angle_deg": math.degrees(angle)} if num else None,
            "variance_shares": self.shares if num else None,
        })


def propagate(result: Equilibrium, sigmas: Sequence[Sigma], options: SensitivityOptions | None = None) -> Propagation:
    """First-order uncertainty of the tip, the angles and the total angle of an equilibrium.

    Parameters
    ----------
    result : Equilibrium
    sigmas : sequence of Sigma
        From :func:`resolve_sigmas` for ``result.scene``.
    options : SensitivityOptions, optional
    """
    sigmas = _checked_sigmas(result.scene if isinstance(result, Equilibrium) else None, sigmas)
    names = [s.name for s in sigmas]
    sens = sensitivities(result, names, options)
    n = result.scene.segments
    nan2 = np.full((2, 2), np.nan)
    if sens.status in ("near_fold", "not_stable"):
        return Propagation(sigmas, sens.status, sens.message, np.full((n, n), np.nan), nan2, math.nan, {}, result.tip[:2].copy(), result.total_angle_deg)
    sd = np.array([s.sigma for s in sigmas])
    with np.errstate(over="ignore", invalid="ignore"):
        S = np.vstack([sens.dtheta, sens.dtip, sens.dtotal[None, :]]) * sd[None, :]  # each column: one parameter's 1-sigma effect
    with np.errstate(over="ignore", invalid="ignore"):
        cov = S @ S.T
    if not np.all(np.isfinite(cov)):  # a sigma so large that its square overflows: no numbers, said so
        given = ", ".join(s.given for s in sigmas)
        message = f"the first-order covariance of {given} overflows (not a finite number): the sigmas are far beyond the model's range"
        return Propagation(sigmas, "overflow", message, np.full((n, n), np.nan), nan2, math.nan, {}, result.tip[:2].copy(), result.total_angle_deg)
    shares = variance_shares(S[n:], names, OUTPUTS)
    status, message = linear_range(sigmas, sens.fold_distance)
    return Propagation(
        sigmas=sigmas, status=status, message=message, cov_theta=cov[:n, :n], cov_tip=cov[n:n + 2, n:n + 2],
        var_total=float(cov[n + 2, n + 2]), shares=shares, nominal_tip=result.tip[:2].copy(), nominal_total_deg=result.total_angle_deg,
    )


def variance_shares(effects: np.ndarray, names: Sequence[str], outputs: Sequence[tuple[str, str]]) -> dict:
    """Each parameter's share of each output's first-order variance; ``effects`` (one row per
    output, one column per parameter) are the parameters' 1-sigma effects."""
    shares = {}
    for k, (out, _) in enumerate(outputs):
        row = effects[k] ** 2
        total = float(row.sum())
        shares[out] = {name: (float(v) / total if total > 0 else 0.0) for name, v in zip(names, row)}
    return shares


def linear_range(sigmas: Sequence[Sigma], fold_distance: np.ndarray, what: str = "the fold") -> tuple[str, str]:
    """``("ok", "")``, or ``("beyond_linear_range", why)`` when 3 sigma of a parameter reaches half
    its estimated distance to ``what`` (:attr:`esba.analysis.sensitivity.Sensitivities.fold_distance`)."""
    far = [(s, d) for s, d in zip(sigmas, fold_distance) if math.isfinite(d) and 3.0 * s.sigma >= 0.5 * abs(d)]
    if not far:
        return "ok", ""
    return "beyond_linear_range", "; ".join(
        f"3 sigma of {s.name} ({3 * s.sigma:.3g} {s.unit}) reaches {what} estimated {0.5 * abs(d):.3g} {s.unit} away"
        for s, d in far
    ) + ": the first-order uncertainty cannot be trusted there (check it with Monte Carlo)"


# ---------------------------------------------------------------------------------------------
# Monte Carlo


@dataclass(frozen=True)
class MonteCarloOptions:
    """Settings of :func:`monte_carlo`, validated on creation.

    Parameters
    ----------
    samples : int
        Parameter sets drawn (10 to ``MAX_SAMPLES``; 10 000 is the usual check).
    seed : int
        Seed of NumPy's generator (>= 0): the same seed, the same samples, whatever the chunking.
    chunk : int
        Samples per independent chunk (>= 1).
    agree_rel : float
        First order and Monte Carlo *agree* when every standard deviation differs by at most this
        fraction plus two standard errors of the Monte Carlo's own sd (0.7 % each at 10 000
        samples, 2.2 % at 1000).
    batch : BatchOptions or None
        Settings of the batch path. None: compiled C when a compiler is found and there are at
        least 500 samples (n <= 32), else CasADi's interpreter, chosen once for all chunks.

    >>> MonteCarloOptions(samples=5)
    Traceback (most recent call last):
    ...
    esba.calibration.sigmas.UncertaintyError: samples=5: expected a whole number >= 10
    """

    samples: int = 10_000
    seed: int = 0
    chunk: int = 2500
    agree_rel: float = 0.05
    batch: BatchOptions | None = None

    def __post_init__(self) -> None:
        checks.whole("samples", self.samples, 10, UncertaintyError)
        if self.samples > MAX_SAMPLES:
            raise UncertaintyError(f"samples={self.samples}: at most {MAX_SAMPLES} (split a larger study into runs with other seeds)")
        checks.whole("seed", self.seed, 0, UncertaintyError)
        checks.whole("chunk", self.chunk, 1, UncertaintyError)
        v = self.agree_rel
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not 0.0 < v < 1.0:
            raise UncertaintyError(f"agree_rel={v!r}: expected a number with 0 < agree_rel < 1")
        if self.batch is not None and not isinstance(self.batch, BatchOptions):
            raise UncertaintyError(f"batch={self.batch!r}: expected BatchOptions or None")


def draw_samples(sigmas: Sequence[Sigma], samples: int, seed: int) -> np.ndarray:
    """All parameter samples, shape (len(sigmas), samples), in the parameters' units.

    One generator (``numpy.random.default_rng(seed)``) draws every column in order, so a sample
    does not depend on how the samples are later split.
    """
    sigmas = _checked_sigmas(None, sigmas)
    samples = checks.whole("samples", samples, 1, UncertaintyError, high=MAX_SAMPLES, why="the Monte Carlo's bound")
    seed = checks.whole("seed", seed, 0, UncertaintyError)
    check_samples(samples, 1, len(sigmas))
    rng = np.random.default_rng(seed)
    out = np.empty((len(sigmas), samples))
    for i, s in enumerate(sigmas):
        if s.distribution == "uniform":
            out[i] = s.nominal + rng.uniform(-s.half_width, s.half_width, samples)
        else:
            out[i] = s.nominal + s.sigma * rng.standard_normal(samples)
    return out


#: Codes of :func:`solve_samples`: a stable equilibrium, a sample the scene's rules forbid, no stable equilibrium.
SAMPLE_OK, SAMPLE_INVALID, SAMPLE_NOT_OK = 0, 1, 2


def solve_samples(base: Scene, names: Sequence[str], values: np.ndarray, options: BatchOptions) -> dict[str, np.ndarray]:
    """Solve one chunk of samples on the batch path: a pure function of its arguments.

    Parameters
    ----------
    base : Scene
        The scene the samples vary (it fixes the model: segments, effects, variant).
    names : sequence of str
        The varied parameters (rows of ``values``).
    values : ndarray, shape (len(names), k)
        The samples, in the parameters' units.
    options : BatchOptions
        Fixed for all chunks (so that every chunk runs the same code).

    Returns
    -------
    dict of ndarray
        ``code`` (k,) (``SAMPLE_OK``, ``SAMPLE_INVALID``, ``SAMPLE_NOT_OK``), ``theta`` (k, n) rad,
        ``tip`` (k, 2) mm, ``total_angle`` (k,) rad, ``pressure`` (k,) MPa; NaN where not ok.
    """
    names = tuple(names)
    values = np.asarray(values, dtype=float).reshape(len(names), -1)
    k, n = values.shape[1], base.segments
    code = np.full(k, SAMPLE_INVALID)
    theta = np.full((k, n), np.nan)
    tip = np.full((k, 2), np.nan)
    pressure = np.full(k, np.nan)
    scenes: list[Scene] = []
    valid: list[int] = []
    for i in range(k):
        try:
            scenes.append(with_parameters(base, dict(zip(names, values[:, i]))))
            valid.append(i)
        except SceneError:
            continue
    if valid:
        model = base.model()
        angle_mode = base.pressure is None
        rows = [s.parameters(0.0 if angle_mode else s.pressure) for s in scenes]
        arrays = {p: np.array([r[p] for r in rows]) for p in model.parameters}
        target = np.radians([s.target_angle_deg for s in scenes]) if angle_mode else None
        r = solve_arrays(model, arrays, target_angle=target, options=options)
        idx = np.asarray(valid)
        good = r.ok
        code[idx] = np.where(good, SAMPLE_OK, SAMPLE_NOT_OK)
        theta[idx[good]] = r.theta[good]
        tip[idx[good]] = r.tip[good, :2]
        pressure[idx] = r.pressure
    return {"code": code, "theta": theta, "tip": tip, "total_angle": np.sum(theta, axis=1), "pressure": pressure}


def _batch_options(options: MonteCarloOptions, scene: Scene) -> BatchOptions:
    if options.batch is not None:
        return options.batch
    compiled = compiler() is not None and options.samples >= BatchOptions().compile_min and scene.segments <= AUTO_COMPILE_MAX_N
    return BatchOptions(compile="always" if compiled else "never")


@dataclass(frozen=True, eq=False)
class MonteCarlo:
    """Monte Carlo of an equilibrium's uncertainty on the batch path.

    Attributes
    ----------
    sigmas : tuple of Sigma
    options : MonteCarloOptions
    samples : ndarray, shape (m, N)
        The parameter samples drawn.
    code : ndarray, shape (N,)
        Per sample: 0 a stable equilibrium, 1 outside the scene's rules, 2 no stable equilibrium.
    tip : ndarray, shape (N, 2)
    total_angle : ndarray, shape (N,)
        rad (NaN where not ok).
    backend : str
        How the batch path ran.
    """

    sigmas: tuple[Sigma, ...]
    options: MonteCarloOptions
    samples: np.ndarray
    code: np.ndarray
    theta: np.ndarray
    tip: np.ndarray
    total_angle: np.ndarray
    backend: str = field(default="")

    #: The outputs (name, unit) whose statistics :meth:`values` gives.
    outputs: ClassVar[tuple[tuple[str, str], ...]] = OUTPUTS

    @property
    def ok(self) -> np.ndarray:
        """Samples that reached a stable equilibrium."""
        return self.code == SAMPLE_OK

    @property
    def counts(self) -> dict[str, int]:
        """Samples in all, solved, outside the scene's rules, without a stable equilibrium."""
        return {
            "samples": int(self.code.size),
            "ok": int(np.sum(self.code == SAMPLE_OK)),
            "invalid": int(np.sum(self.code == SAMPLE_INVALID)),
            "not_ok": int(np.sum(self.code == SAMPLE_NOT_OK)),
        }

    def values(self, output: str) -> np.ndarray:
        """The solved samples of ``tip_x``, ``tip_y`` (mm) or ``total_angle`` (deg)."""
        ok = self.ok
        return {"tip_x": self.tip[ok, 0], "tip_y": self.tip[ok, 1], "total_angle": np.degrees(self.total_angle[ok])}[output]

    def mean(self, output: str) -> float:
        """Mean of an output over the solved samples."""
        v = self.values(output)
        return float(np.mean(v)) if v.size else math.nan

    def std(self, output: str) -> float:
        """Standard deviation (ddof = 1) of an output over the solved samples."""
        v = self.values(output)
        return float(np.std(v, ddof=1)) if v.size > 1 else math.nan

    @property
    def cov_tip(self) -> np.ndarray:
        """Covariance of the tip over the solved samples, mm^2."""
        t = self.tip[self.ok]
        return np.cov(t.T) if len(t) > 2 else np.full((2, 2), np.nan)

    def to_dict(self) -> dict:
        """JSON-ready summary (no per-sample arrays)."""
        return jsonsafe.clean({
            "samples": self.options.samples,
            "seed": self.options.seed,
            "chunk": self.options.chunk,
            "counts": self.counts,
            "mean": {o: self.mean(o) for o, _ in self.outputs},
            "std": {o: self.std(o) for o, _ in self.outputs},
            "cov_tip_mm2": self.cov_tip.tolist(),
            "backend": self.backend,
        })


def sample_bytes(samples: int, n: int, parameters: int = 1) -> int:
    """Estimated memory (bytes) a Monte Carlo of ``samples`` keeps: each sample's parameters,
    angles, tip and outcome, twice while the chunks are joined.

    >>> sample_bytes(10_000, 3, 2)
    2720000
    """
    return int(samples) * 2 * 8 * (parameters + n + 12)


def check_samples(samples: int, n: int, parameters: int = 1) -> None:
    """An :class:`UncertaintyError` when the samples would not fit in :data:`esba.statics.batch_options.MAX_BATCH_BYTES`."""
    need = sample_bytes(samples, n, parameters)
    if need > MAX_BATCH_BYTES:
        most = MAX_BATCH_BYTES // sample_bytes(1, n, parameters)
        raise UncertaintyError(
            f"samples={samples} at n = {n} would keep about {need / 2**30:.1f} GiB of samples (limit "
            f"{MAX_BATCH_BYTES / 2**30:g} GiB): at most {most} at this n"
        )


def check_samples3d(samples: int) -> None:
    """An :class:`UncertaintyError` for more samples than a 3-D Monte Carlo takes (:data:`MAX_SAMPLES_3D`).

    >>> check_samples3d(200_000)
    Traceback (most recent call last):
    ...
    esba.calibration.sigmas.UncertaintyError: samples=200000: at most 100000 in 3-D (each sample is a load history of Newton solves in Python, about 10 ms at n = 3); split a larger study into runs with other seeds
    """
    if samples > MAX_SAMPLES_3D:
        raise UncertaintyError(f"samples={samples}: at most {MAX_SAMPLES_3D} in 3-D (each sample is a load history of Newton solves in Python, "
                               "about 10 ms at n = 3); split a larger study into runs with other seeds")


def _in_this_process(scene, fn, bounds, args_of, on_result, progress: str | None) -> None:
    """Each chunk in this process, in order (with a tqdm bar on stderr when ``progress`` names it)."""
    bar = None
    if progress:
        from tqdm.auto import tqdm

        bar = tqdm(total=sum(b - a for a, b in bounds), unit="pt", desc=progress, leave=False, disable=None)  # None: only on a terminal
    try:
        for a, b in bounds:
            on_result(a, b, fn(*args_of(a, b)))
            if bar is not None:
                bar.update(b - a)
    finally:
        if bar is not None:
            bar.close()


def monte_carlo(
    scene: Scene,
    sigmas: Sequence[Sigma],
    options: MonteCarloOptions | None = None,
    *,
    chunks: Sequence[int] | None = None,
    execute: Callable | None = None,
    solved: dict[str, np.ndarray] | None = None,
    on_chunk: Callable[[int, dict[str, np.ndarray]], None] | None = None,
    progress: bool = False,
) -> MonteCarlo:
    """Sample the uncertain parameters and solve every sample on the batch path.

    Parameters
    ----------
    scene : Scene
        The nominal scene (the samples vary its parameters).
    sigmas : sequence of Sigma
        From :func:`resolve_sigmas` for ``scene``.
    options : MonteCarloOptions, optional
    chunks : sequence of int, optional
        Chunk sizes summing to the samples left to solve (default: ``options.chunk`` each). Any
        split gives the same result.
    execute : callable, optional
        ``execute(scene, fn, bounds, args_of, on_result, progress)`` runs ``fn(*args_of(a, b))`` for
        each chunk ``(a, b)`` of ``bounds`` and calls ``on_result(a, b, result)`` in chunk order:
        where the chunks run (:func:`esba.studies.monte_carlo.monte_carlo` passes one that runs
        them on Dask workers). Default: in this process, one after the other. Same result.
    solved : dict of ndarray, optional
        ``code``, ``theta``, ``tip``, ``total_angle`` of the first k samples, already solved (a
        resumed study, :mod:`esba.studies.monte_carlo`): only samples k to N are solved.
    on_chunk : callable, optional
        ``on_chunk(start, part)`` with the :func:`solve_samples` arrays of each chunk, in order, as
        soon as it is solved (to write them to a file).
    progress : bool
        A tqdm bar on stderr over the samples of completed chunks.
    """
    options, sigmas = check_monte_carlo(scene, sigmas, options)
    names = tuple(s.name for s in sigmas)
    batch = _batch_options(options, scene)

    def before(bounds):
        if batch.compile == "always" and bounds:
            prepare(scene.model(), batch, scene.pressure is None)  # compiled once here, not once per worker

    values, merged = run_samples(scene, sigmas, options, solve_samples, lambda v: (scene, names, v, batch), ("code", "theta", "tip", "total_angle"),
                                 chunks=chunks, execute=execute, solved=solved, on_chunk=on_chunk, progress=progress, before=before)
    backend = "compiled C" if batch.compile == "always" else "CasADi's interpreter"
    return MonteCarlo(sigmas, options, values, merged["code"], merged["theta"], merged["tip"], merged["total_angle"], backend)


def check_monte_carlo(scene: Scene, sigmas: Sequence[Sigma], options: MonteCarloOptions | None, three_d: bool = False) -> tuple[MonteCarloOptions, tuple[Sigma, ...]]:
    """The options (default if None) and the sigmas, checked for ``scene`` (its 3-D parameters with ``three_d``) and for memory."""
    options = MonteCarloOptions() if options is None else options
    if not isinstance(options, MonteCarloOptions):
        raise UncertaintyError(f"options={options!r}: expected MonteCarloOptions")
    if not isinstance(scene, Scene):
        raise UncertaintyError(f"scene={scene!r}: expected a Scene")
    if three_d:
        check_samples3d(options.samples)
    check_samples(options.samples, 3 * scene.segments if three_d else scene.segments, len(sigmas))
    return options, _checked_sigmas(scene, sigmas, three_d)


def run_samples(
    scene: Scene,
    sigmas: Sequence[Sigma],
    options: MonteCarloOptions,
    fn: Callable[..., dict[str, np.ndarray]],
    args_of: Callable[[np.ndarray], tuple],
    keys: Sequence[str],
    *,
    chunks: Sequence[int] | None = None,
    execute: Callable | None = None,
    solved: dict[str, np.ndarray] | None = None,
    on_chunk: Callable[[int, dict[str, np.ndarray]], None] | None = None,
    progress: bool = False,
    before: Callable[[list], None] | None = None,
) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """Draw every sample (:func:`draw_samples`) and solve samples k..N in chunks, each
    ``fn(*args_of(values[:, a:b]))`` (a pure function returning arrays, one row per sample): the
    chunking, ``execute``, ``solved``, ``on_chunk`` and ``progress`` of :func:`monte_carlo`, whose
    planar and 3-D Monte Carlos (:mod:`esba.calibration.uncertainty3d`) both run through here.
    ``before(bounds)`` runs once before the chunks. Returns the samples and the arrays ``keys``
    of every sample, in order."""
    values = draw_samples(sigmas, options.samples, options.seed)
    N = options.samples
    done = 0 if solved is None else len(solved["code"])
    if not 0 <= done <= N:
        raise UncertaintyError(f"solved: {done} samples given; expected at most samples={N}")
    if chunks is None:
        chunks = [min(options.chunk, N - start) for start in range(done, N, options.chunk)]
    chunks = [checks.whole("chunk", c, 1, UncertaintyError) for c in chunks]
    if sum(chunks) != N - done:
        raise UncertaintyError(f"chunks={list(chunks)}: sizes must add up to samples={N}" + (f" less the {done} solved" if done else ""))
    bounds = []
    for size in chunks:
        start = bounds[-1][1] if bounds else done
        bounds.append((start, start + size))
    if before is not None:
        before(bounds)
    parts: list[dict[str, np.ndarray]] = [] if solved is None else [solved]

    def keep(a: int, b: int, part: dict[str, np.ndarray]) -> None:
        if on_chunk is not None:
            on_chunk(a, part)
        parts.append(part)

    run = _in_this_process if execute is None else execute
    run(scene, fn, bounds, lambda a, b: args_of(values[:, a:b]), keep, "esba Monte Carlo" if progress else None)
    return values, {k: np.concatenate([p[k] for p in parts]) for k in keys}


@dataclass(frozen=True)
class Agreement:
    """First order against Monte Carlo, output by output.

    Attributes
    ----------
    rows : tuple of dict
        Per output (``tip_x``, ``tip_y`` in mm, ``total_angle`` in deg): ``std_first_order``,
        ``std_monte_carlo``, ``std_ratio`` (Monte Carlo / first order), ``std_error_monte_carlo``
        (the Monte Carlo standard deviation's own standard error, s / sqrt(2 (N - 1))),
        ``mean_shift_sigmas`` ((Monte Carlo mean - nominal) / first-order sigma).
    agree : bool
        Every standard deviation ratio within ``agree_rel`` of 1 (plus two standard errors of the
        Monte Carlo sd, 1 / sqrt(2 (N - 1)) relative each), and no sample without a stable
        equilibrium (the mean shifts, nonlinear effects, are reported, not judged).
    verdict : str
        One sentence.
    """

    rows: tuple[dict, ...]
    agree: bool
    verdict: str

    def to_dict(self) -> dict:
        """JSON-ready form."""
        return jsonsafe.clean({"agree": self.agree, "verdict": self.verdict, "outputs": list(self.rows)})


def compare(first: Propagation, mc: MonteCarlo) -> Agreement:
    """Set first-order propagation and Monte Carlo side by side; say whether they agree."""
    if not isinstance(first, Propagation) or not isinstance(mc, MonteCarlo):
        raise UncertaintyError(f"compare({type(first).__name__}, {type(mc).__name__}): expected a Propagation (propagate) and a MonteCarlo (monte_carlo)")
    tol = mc.options.agree_rel
    counts = mc.counts
    if first.outputs != mc.outputs:
        raise UncertaintyError(f"compare: the first order gives {', '.join(o for o, _ in first.outputs)}, the Monte Carlo {', '.join(o for o, _ in mc.outputs)}: "
                               "compare a planar propagation with a planar Monte Carlo, a 3-D one with a 3-D one")
    rows = []
    nominal = {o: first.nominal(o) for o, _ in first.outputs}
    for out, unit in mc.outputs:
        s1 = first.std(out) if first.has_numbers else math.nan
        s2 = mc.std(out)
        k = max(counts["ok"], 2)
        rows.append({
            "output": out,
            "unit": unit,
            "nominal": nominal[out],
            "std_first_order": s1,
            "std_monte_carlo": s2,
            "std_ratio": s2 / s1 if s1 > 0 else math.nan,
            "std_error_monte_carlo": s2 / math.sqrt(2.0 * (k - 1)),
            "mean_monte_carlo": mc.mean(out),
            "mean_shift_sigmas": (mc.mean(out) - nominal[out]) / s1 if s1 > 0 else math.nan,
        })
    # an output that does not move at all (std 0 both ways) agrees trivially
    def fine(r):
        if r["std_first_order"] == 0 and r["std_monte_carlo"] < 1e-9:
            return True
        # the Monte Carlo sd is itself uncertain: allow two of its standard errors on top of the tolerance
        return abs(r["std_ratio"] - 1.0) <= tol + 2.0 * r["std_error_monte_carlo"] / r["std_monte_carlo"]

    agree = bool(first.has_numbers and counts["not_ok"] == 0 and counts["ok"] > 1 and all(fine(r) for r in rows))
    shifts = [abs(r["mean_shift_sigmas"]) for r in rows if math.isfinite(r["mean_shift_sigmas"])]
    shift = f"; the Monte Carlo means move by up to {max(shifts):.2g} sigma (a nonlinear effect first order does not see)" if shifts else ""
    if not first.has_numbers:
        verdict = f"no first-order answer ({first.status}): {first.message}"
    elif counts["ok"] < 2:
        verdict = (
            f"no comparison: {counts['ok']} of {counts['samples']} Monte Carlo samples solved ({counts['invalid']} outside the "
            f"scene's rules, {counts['not_ok']} without a stable equilibrium), too few for a standard deviation"
        )
    elif agree:
        worst = max(abs(r["std_ratio"] - 1.0) for r in rows if math.isfinite(r["std_ratio"]))
        verdict = (
            f"first order and Monte Carlo ({counts['ok']} of {counts['samples']} samples solved) agree: standard deviations "
            f"within {100 * worst:.1f} % (tolerance {100 * tol:g} % and two Monte Carlo standard errors, "
            f"{200 / math.sqrt(2.0 * (counts['ok'] - 1)):.1f} %){shift}"
        )
    else:
        why = []
        if counts["not_ok"]:
            why.append(f"{counts['not_ok']} samples reach no stable equilibrium")
        for r in rows:
            if not fine(r):
                why.append(
                    f"{r['output']}: Monte Carlo sigma {r['std_monte_carlo']:.3g} vs first order {r['std_first_order']:.3g} {r['unit']} "
                    f"(ratio {r['std_ratio']:.3g})"
                )
        verdict = "first order is poor here: " + "; ".join(why) + shift
    if counts["invalid"] and counts["ok"] >= 2:
        verdict += f" ({counts['invalid']} samples fell outside the scene's rules and were left out)"
    return Agreement(tuple(rows), agree, verdict)
