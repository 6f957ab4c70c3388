"""The coverage estimate: from the features of a view (`vprobot.stopping.features`) to a mean
and a standard deviation of the current coverage.

An ensemble of `MEMBERS` small networks (two hidden layers of `HIDDEN` tanh units), each
stating a Gaussian over the coverage (its mean through a sigmoid, inside [0, 1]) and trained
with the Gaussian negative log-likelihood on standardised features, from its own initial
weights. Each member keeps the weights of its best validation likelihood (model selection on
the validation list, never a test list). The ensemble's estimate is the mixture's mean and
standard deviation, so that the members' disagreement on unfamiliar inputs widens the stated
uncertainty.

As fitted, that disagreement is far too small for a part family the rollouts never showed:
there the estimate is biased, by an amount that depends on the family. So the disagreement's
share of the variance is scaled up (`unseen_scale`), by the least factor that made the 95 %
intervals hold on families left out of the fit in turn (`vprobot.stop_studies.folds`,
`vprobot.stop_studies.calibration.unseen_scale`): the uncertainty stated for any part is the one
that held on families the estimate had not seen, and it grows where the members disagree (on
unfamiliar inputs) rather than everywhere.

What the estimator was fit on is recorded with it (`TrainingDomain`: each feature's range over
the training rows, the sensor and its sensing model, the planners, and how much unexplored
space the training views showed where the estimate claimed the goal), and `EstimateTracker`
states the estimate as a stop rule may use it: refused for another sensor, another sensing model
or a feature far outside its range, widened a little outside it, never raised by a view that
added no new surface, and held back from a stop where more space is unexplored than on any
training view it claimed the goal on (cavities no view has seen into, which the estimate takes
for solid material).

Training uses torch; `estimate` is plain numpy, so that a stop rule needs neither torch nor a
pickle: the weights are stored as arrays in an `.npz` file.
"""

from __future__ import annotations

import dataclasses
import functools
import itertools
import zipfile
from collections.abc import Sequence
from pathlib import Path
from statistics import NormalDist

import numpy as np

from vprobot.config import Config, SensorConfig, available_sensors, sensor_preset
from vprobot.files.atomic import write_arrays
from vprobot.files.paths import ESTIMATOR_DIR

MEMBERS = 5
HIDDEN = 32
STEPS = 3000
CHECK_EVERY = 25
"""Steps between validation checks (early stopping: the best checked weights are kept)."""
LEARNING_RATE = 3e-3
WEIGHT_DECAY = 1e-4
MIN_STD = 1e-3
"""Floor of a member's stated standard deviation (coverage is known to no better anyway)."""
FORMAT = 4
"""Format 4 may hold the limits on unexplored space of the claims (`TrainingDomain.claimed`),
format 3 the training domain (the folds' estimators have none), format 2 adds the widening for
unseen families; older files load without them."""
NEW_SURFACE = 0.002
"""A view that grew the occupied voxels by less than this share added no new surface (on the
training rollouts such views raised the true coverage by 0.2 pp on average)."""
WIDEN_PER_RANGE = 4.0
"""A feature outside its training range by d ranges multiplies the std by 1 + this x d."""
REFUSE_RANGES = 0.25
"""A feature farther than this many ranges outside its training range refuses the estimate."""
UNEXPLORED = ("unknown", "rear_side", "open_surface", "hull_unknown")
"""The features that measure space not explored yet (`vprobot.stopping.features`)."""
CLAIM_QUANTILE = 0.98
"""The limit on each `UNEXPLORED` feature for a stop: this quantile of it over the training
views on which the estimate claimed the goal (chosen on the validation list and the foreign
parts of sets a and b, then frozen; results/stop_estimate/README.md)."""
BUNDLED_ESTIMATOR = ESTIMATOR_DIR / "estimator.npz"
"""The estimator of the paper's sensor (its README says how it was fit)."""
BUNDLED_ESTIMATORS = (BUNDLED_ESTIMATOR, ESTIMATOR_DIR / "structured_light" / "estimator.npz")
"""The estimators `--stop estimate` chooses from unless told otherwise: the first fitted on the
run's sensor and sensing model (`bundled_estimator`)."""


def widened_std(variance: np.ndarray, disagreement: np.ndarray,
                unseen_scale: float) -> np.ndarray:
    """The standard deviation an estimate states: its mixture's variance plus `unseen_scale`
    times the members' disagreement (`CoverageEstimator.mixture`), at least `MIN_STD`."""
    return np.sqrt(np.maximum(variance + unseen_scale * disagreement, MIN_STD ** 2))

SENSOR_GEOMETRY = ("fov_deg", "near_m", "far_m", "working_distance_m")
"""What of a sensor the features depend on (they count points and blocked pixels per pixel, so
not its resolution)."""


def sensor_geometry(sensor: SensorConfig) -> tuple[float, ...]:
    """The sensor's opening angles, range and working distance, as `SENSOR_GEOMETRY` lists."""
    return (*sensor.fov_deg, sensor.near_m, sensor.far_m, sensor.working_distance_m)


def sensor_name(geometry: Sequence[float]) -> str:
    """The preset (`configs/sensors/`) of a sensor geometry, else `custom`."""
    for name in available_sensors():
        if np.allclose(sensor_geometry(sensor_preset(name)), geometry):
            return name
    return "custom"


@dataclasses.dataclass(frozen=True)
class TrainingDomain:
    """What an estimator was fit on, to tell inputs unlike it.

    Attributes:
        low: Each feature's least value over the training rows.
        high: Its greatest.
        sensor: The sensor's `sensor_geometry` in the rollouts.
        planners: The rollouts' planners.
        claimed: Per feature, the most of it a stop may see (`claim_limits`; +inf: any);
            None: not recorded (files before format 4).
        sensing: The sensing model of the rollouts (`ideal` or `structured_light`); files that
            do not record it were fit before the model existed, on `ideal`.

    Raises:
        ValueError: For ranges of different lengths, not finite or with low > high, a sensor
            geometry of another length, or limits of another length or NaN.
    """

    low: np.ndarray
    high: np.ndarray
    sensor: tuple[float, ...]
    planners: tuple[str, ...]
    claimed: np.ndarray | None = None
    sensing: str = "ideal"

    def __post_init__(self) -> None:
        low, high = np.asarray(self.low, dtype=float), np.asarray(self.high, dtype=float)
        if (low.ndim != 1 or low.shape != high.shape or not np.isfinite([*low, *high]).all()
                or (low > high).any()):
            raise ValueError(f"training ranges need finite low <= high of one length, got "
                             f"shapes {low.shape} and {high.shape}")
        if len(self.sensor) != len(SENSOR_GEOMETRY) + 1:  # fov_deg holds two angles
            raise ValueError(f"the sensor geometry holds {len(SENSOR_GEOMETRY) + 1} values "
                             f"({', '.join(SENSOR_GEOMETRY)}), got {len(self.sensor)}")
        if self.claimed is not None and (np.shape(self.claimed) != low.shape
                                         or np.isnan(self.claimed).any()):
            raise ValueError(f"the limits of the claims need one value per feature "
                             f"({len(low)}), none NaN, got shape {np.shape(self.claimed)}")

    @classmethod
    def of(cls, features: np.ndarray, sensor: SensorConfig, planners: Sequence[str],
           claimed: np.ndarray | None = None) -> TrainingDomain:
        """The domain of training rows (n, features) from rollouts of `sensor` and `planners`,
        with the limits of the claims (`claim_limits`) if given."""
        x = np.asarray(features, dtype=float)
        return cls(x.min(axis=0), x.max(axis=0), sensor_geometry(sensor), tuple(planners),
                   claimed, sensor.sensing)

    def sensor_mismatch(self, sensor: SensorConfig) -> str | None:
        """Why frames of `sensor` are not those the estimate was fitted on, or None."""
        geometry = sensor_geometry(sensor)
        if not np.allclose(geometry, self.sensor):
            return (f"fitted on sensor {_describe(self.sensor)}, this run uses "
                    f"{_describe(geometry)}")
        if sensor.sensing != self.sensing:
            # What a frame holds, and so every feature, depends on the sensing model.
            return f"fitted on the {self.sensing} sensing model, this run uses {sensor.sensing}"
        return None

    def outside(self, features: np.ndarray) -> np.ndarray:
        """How far each feature lies outside its range, in units of the range (0 inside; a
        feature whose training rows all had one value is infinitely far from any other)."""
        x = np.asarray(features, dtype=float)
        beyond = np.maximum(np.maximum(self.low - x, x - self.high), 0.0)
        width = self.high - self.low
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.where(beyond > 0.0, beyond / width, 0.0)

    def unexplored(self, features: np.ndarray) -> int | None:
        """The first feature above the most a stop may see (`claimed`), or None."""
        if self.claimed is None:
            return None
        above = np.flatnonzero(np.asarray(features, dtype=float) > self.claimed)
        return int(above[0]) if len(above) else None


def _softplus(x: np.ndarray) -> np.ndarray:
    return np.logaddexp(0.0, x)


@dataclasses.dataclass(frozen=True)
class CoverageEstimator:
    """Features to a Gaussian estimate of the coverage.

    Attributes:
        features: The feature names, in the order of a feature vector.
        shift: Subtracted from the features before the networks (len(features),).
        scale: Divides them after (len(features),).
        layers: Per member, the (weight, bias) pairs of its layers; the last layer's two
            outputs are the mean's logit and the standard deviation's softplus argument.
        unseen_scale: The variance stated adds this many times the members' disagreement
            (the variance of their means) to the mixture's own (0: none).
        domain: What it was fit on (None: not recorded, files before format 3).

    Raises:
        ValueError: For a negative or infinite `unseen_scale`, arrays of the wrong shapes, a
            weight that is not finite, a scale that is not finite and positive, or a domain
            of another feature count.
    """

    features: tuple[str, ...]
    shift: np.ndarray
    scale: np.ndarray
    layers: tuple[tuple[tuple[np.ndarray, np.ndarray], ...], ...]
    unseen_scale: float = 0.0
    domain: TrainingDomain | None = None

    def __post_init__(self) -> None:
        if not 0.0 <= self.unseen_scale < np.inf:
            raise ValueError(f"unseen_scale must be finite and >= 0, got {self.unseen_scale}")
        count = len(self.features)
        if np.shape(self.shift) != (count,) or np.shape(self.scale) != (count,):
            raise ValueError(f"shift and scale need one value per feature ({count}), got "
                             f"shapes {np.shape(self.shift)} and {np.shape(self.scale)}")
        # A zero or NaN scale would make every estimate NaN, which no rule ever stops on.
        if not (np.isfinite(self.shift).all() and np.isfinite(self.scale).all()
                and (np.asarray(self.scale) > 0.0).all()):
            raise ValueError("shift must be finite and scale finite and > 0")
        if not self.layers:
            raise ValueError("an estimator needs at least one member")
        for m, member in enumerate(self.layers):
            width = count
            for k, (weight, bias) in enumerate(member):
                last = k == len(member) - 1
                if (np.ndim(weight) != 2 or np.shape(weight)[0] != width
                        or np.shape(bias) != np.shape(weight)[1:]
                        or (last and np.shape(weight)[1] != 2)):
                    raise ValueError(f"member {m} layer {k}: weight {np.shape(weight)} and bias "
                                     f"{np.shape(bias)} do not take {width} inputs"
                                     + (" to 2 outputs" if last else ""))
                if not (np.isfinite(weight).all() and np.isfinite(bias).all()):
                    raise ValueError(f"member {m} layer {k}: a weight is not finite")
                width = np.shape(weight)[1]
        if self.domain is not None and len(self.domain.low) != count:
            raise ValueError(f"the training domain has {len(self.domain.low)} features, the "
                             f"estimator {count}")

    def estimate(self, features: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The estimated coverage and its standard deviation (widened by `unseen_scale`).

        Args:
            features: One feature vector (len(features),) or a batch (n, len(features)).

        Returns:
            The mean and the standard deviation, each of the batch's shape (a scalar array for
            one vector).

        Raises:
            ValueError: If the feature count differs from the estimator's.
        """
        mean, variance, disagreement = self.mixture(features)
        return mean, widened_std(variance, disagreement, self.unseen_scale)

    def mixture(self, features: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The ensemble's mean, its variance as fitted (no widening), and the members'
        disagreement (the variance of their means, a part of that variance).

        Raises:
            ValueError: If the feature count differs from the estimator's.
        """
        x = np.asarray(features, dtype=float)
        if x.shape[-1:] != (len(self.features),):
            raise ValueError(f"expected {len(self.features)} features ({', '.join(self.features)})"
                             f", got shape {x.shape}")
        x = (x - self.shift) / self.scale
        means, variances = [], []
        for member in self.layers:
            h = x
            for weight, bias in member[:-1]:
                h = np.tanh(h @ weight + bias)
            weight, bias = member[-1]
            out = h @ weight + bias
            mean = 1.0 / (1.0 + np.exp(-out[..., 0]))
            std = _softplus(out[..., 1]) + MIN_STD
            means.append(mean)
            variances.append(std ** 2)
        mean = np.mean(means, axis=0)
        disagreement = np.var(means, axis=0)
        # The mixture's variance: the members' own plus their spread about the mean.
        return mean, np.mean(variances, axis=0) + disagreement, disagreement

    def save(self, path: str | Path) -> Path:
        """Write the estimator to an `.npz` file (atomically)."""
        path = Path(path)
        arrays = {"format": np.array(FORMAT), "features": np.array(self.features),
                  "shift": self.shift, "scale": self.scale,
                  "shape": np.array([len(self.layers), len(self.layers[0])]),
                  "unseen_scale": np.array(self.unseen_scale)}
        if self.domain is not None:
            arrays |= {"domain_low": self.domain.low, "domain_high": self.domain.high,
                       "domain_sensor": np.array(self.domain.sensor),
                       "domain_planners": np.array(self.domain.planners),
                       "domain_sensing": np.array(self.domain.sensing)}
            if self.domain.claimed is not None:
                arrays["domain_claimed"] = self.domain.claimed
        for m, member in enumerate(self.layers):
            for k, (weight, bias) in enumerate(member):
                arrays[f"w_{m}_{k}"], arrays[f"b_{m}_{k}"] = weight, bias
        return write_arrays(path, arrays)

    @classmethod
    def load(cls, path: str | Path) -> CoverageEstimator:
        """Read an estimator written by `save` (or by an older format).

        Raises:
            ValueError: If the file is missing, not an estimator of a known format, or holds
                arrays of the wrong shapes, weights that are not finite or a scale that is not
                positive (the message names the file).
        """
        try:
            with np.load(Path(path), allow_pickle=False) as data:
                version = int(data["format"])
                if version not in range(1, FORMAT + 1):
                    raise ValueError(f"estimator format {version}, expected 1 to {FORMAT}")
                members, depth = (int(n) for n in data["shape"])
                layers = tuple(tuple((data[f"w_{m}_{k}"], data[f"b_{m}_{k}"])
                                     for k in range(depth)) for m in range(members))
                unseen = float(data["unseen_scale"]) if version >= 2 else 0.0
                domain = (TrainingDomain(data["domain_low"], data["domain_high"],
                                         tuple(float(v) for v in data["domain_sensor"]),
                                         tuple(str(name) for name in data["domain_planners"]),
                                         data["domain_claimed"] if "domain_claimed" in data.files
                                         else None,
                                         str(data["domain_sensing"])
                                         if "domain_sensing" in data.files else "ideal")
                          if "domain_low" in data.files else None)
                return cls(tuple(str(name) for name in data["features"]), data["shift"],
                           data["scale"], layers, unseen, domain)
        # An empty or cut file is an EOFError or a BadZipFile; a wrong array a TypeError.
        except (OSError, EOFError, zipfile.BadZipFile, KeyError, TypeError,
                ValueError) as error:
            raise ValueError(f"cannot read coverage estimator {path}: {error}") from None


def claim_limits(estimator: CoverageEstimator, features: np.ndarray, goal: float,
                 confidence: float) -> np.ndarray:
    """The most of each `UNEXPLORED` feature a stop may see: its `CLAIM_QUANTILE` quantile
    over the training rows (n, features) on which the estimate claimed the goal (its one-sided
    lower bound at `confidence` reached `goal`); +inf for the other features.

    Where the estimate claimed the goal on no training row, nothing shows that a claim holds:
    the limits are -inf (never a stop).
    """
    x = np.asarray(features, dtype=float)
    mean, std = estimator.estimate(x)
    claims = x[mean - NormalDist().inv_cdf(confidence) * std >= goal]
    limits = np.full(x.shape[1], np.inf)
    for name in UNEXPLORED:
        if name in estimator.features:
            column = estimator.features.index(name)
            limits[column] = (np.quantile(claims[:, column], CLAIM_QUANTILE) if len(claims)
                              else -np.inf)
    return limits


def bundled_estimator(sensor: SensorConfig | None = None) -> Path:
    """The bundled estimator fitted on `sensor` and its sensing model (`BUNDLED_ESTIMATORS`);
    the paper sensor's where none is (its estimates are then refused, saying why)."""
    if sensor is not None:
        for path in BUNDLED_ESTIMATORS:
            domain = load_estimator(path).domain
            if domain is not None and domain.sensor_mismatch(sensor) is None:
                return path
    return BUNDLED_ESTIMATOR


def load_estimator(path: str | Path | None = None,
                   sensor: SensorConfig | None = None) -> CoverageEstimator:
    """The estimator of an `.npz` file of `vprobot stop fit`, or (None) the bundled one of
    `sensor` (`bundled_estimator`).

    Raises:
        ValueError: If the file is missing or not an estimator.
    """
    shown = Path(path) if path is not None else bundled_estimator(sensor)
    try:
        modified = shown.stat().st_mtime_ns
    except OSError as error:
        raise ValueError(f"cannot read coverage estimator {shown}: {error}") from None
    return _load(shown.resolve(), modified)


@functools.lru_cache(maxsize=4)
def _load(path: Path, modified: int) -> CoverageEstimator:
    # Cached per file and modification time: an evaluation builds a stop rule every episode.
    return CoverageEstimator.load(path)


def fit(features: np.ndarray, coverage: np.ndarray, validation_features: np.ndarray,
        validation_coverage: np.ndarray, names: Sequence[str], seed: int = 0,
        members: int = MEMBERS, hidden: int = HIDDEN, steps: int = STEPS) -> CoverageEstimator:
    """Train an estimator (see the module docstring); reproducible from `seed`.

    Args:
        features: Training features (n, len(names)).
        coverage: Their true coverage (n,).
        validation_features: Features of the validation rows, for early stopping.
        validation_coverage: Their true coverage.
        names: The feature names.
        seed: Seeds the initial weights.
        members: Networks in the ensemble.
        hidden: Units per hidden layer.
        steps: Full-batch Adam steps (at least `CHECK_EVERY`).

    Raises:
        ValueError: For empty or mismatched arrays, or too few steps.
    """
    import torch

    x = np.asarray(features, dtype=float)
    y = np.asarray(coverage, dtype=float)
    vx = np.asarray(validation_features, dtype=float)
    vy = np.asarray(validation_coverage, dtype=float)
    if (x.ndim != 2 or x.shape[1] != len(names) or len(x) != len(y) or len(x) == 0
            or vx.shape[1:] != x.shape[1:] or len(vx) != len(vy) or len(vx) == 0):
        raise ValueError(f"need non-empty features (n, {len(names)}) with one coverage each, "
                         f"got {x.shape}, {y.shape}, {vx.shape}, {vy.shape}")
    if steps < CHECK_EVERY:
        raise ValueError(f"steps must be at least {CHECK_EVERY}, got {steps}")
    shift = x.mean(axis=0)
    scale = np.where(x.std(axis=0) > 1e-9, x.std(axis=0), 1.0)

    def tensor(array: np.ndarray) -> torch.Tensor:
        return torch.tensor(array, dtype=torch.float64)

    train_x, train_y = tensor((x - shift) / scale), tensor(y)
    check_x, check_y = tensor((vx - shift) / scale), tensor(vy)
    # The members train side by side as one batched network: their losses add up, and Adam's
    # updates are per weight, so each member learns as if alone, from its own initial weights.
    generator = torch.Generator().manual_seed(seed)
    sizes = [len(names), hidden, hidden, 2]
    params = []
    for fan_in, fan_out in itertools.pairwise(sizes):
        bound = fan_in ** -0.5  # torch.nn.Linear's initialisation
        for shape in ((members, fan_in, fan_out), (members, 1, fan_out)):
            params.append(((torch.rand(shape, generator=generator, dtype=torch.float64) * 2 - 1)
                           * bound).requires_grad_())

    def nll(inputs: torch.Tensor, truth: torch.Tensor) -> torch.Tensor:
        """Per member, the mean Gaussian negative log-likelihood (constant dropped)."""
        h = inputs.expand(members, *inputs.shape)
        for k in range(0, len(params) - 2, 2):
            h = torch.tanh(torch.baddbmm(params[k + 1], h, params[k]))
        out = torch.baddbmm(params[-1], h, params[-2])
        mean = torch.sigmoid(out[..., 0])
        std = torch.nn.functional.softplus(out[..., 1]) + MIN_STD
        return (torch.log(std) + 0.5 * ((truth - mean) / std) ** 2).mean(dim=1)

    optimizer = torch.optim.AdamW(params, lr=LEARNING_RATE, weight_decay=WEIGHT_DECAY)
    best = np.full(members, np.inf)
    kept = [param.detach().numpy().copy() for param in params]
    threads = torch.get_num_threads()
    # Matrices this small gain nothing from more threads, and lose much on a busy machine.
    torch.set_num_threads(1)
    try:
        for step in range(steps):
            optimizer.zero_grad()
            nll(train_x, train_y).sum().backward()
            optimizer.step()
            if (step + 1) % CHECK_EVERY == 0:
                with torch.no_grad():
                    score = nll(check_x, check_y).numpy()
                better = score < best
                best = np.where(better, score, best)
                for stored, param in zip(kept, params, strict=True):
                    stored[better] = param.detach().numpy()[better]
    finally:
        torch.set_num_threads(threads)
    if not np.isfinite(best).all():
        raise ValueError("a member never reached a finite validation likelihood")
    layers = tuple(tuple((kept[k][m], kept[k + 1][m, 0]) for k in range(0, len(kept), 2))
                   for m in range(members))
    return CoverageEstimator(tuple(names), shift, scale, layers)


@dataclasses.dataclass(frozen=True)
class Stated:
    """The estimate after a view as `EstimateTracker` states it.

    Attributes:
        mean: The estimated coverage (NaN: refused).
        std: Its standard deviation (NaN: refused).
        note: Why it was refused, widened or kept from the view before, to follow the word
            "estimate" (`not used: ...`; None: as estimated).
        held: Why a stop rule may not stop on it although it is stated (more space unexplored
            than on the training views it claimed the goal on), to follow "estimate"; None:
            it may.
    """

    mean: float
    std: float
    note: str | None = None
    held: str | None = None

    @property
    def refused(self) -> bool:
        return bool(np.isnan(self.mean))


def _describe(geometry: Sequence[float]) -> str:
    fov_x, fov_y, near, far, working = geometry
    return (f"{sensor_name(geometry)!r} ({fov_x:g} x {fov_y:g} deg, {near:g}-{far:g} m, "
            f"working distance {working:g} m)")


class EstimateTracker:
    """An episode's estimates view by view, as `--stop estimate` states and uses them.

    - Another sensor than the fit's (`TrainingDomain.sensor`) or another sensing model
      (`TrainingDomain.sensing`): every estimate is refused.
    - No view acquired yet: refused (nothing to estimate from).
    - A view that grew the occupied voxels by less than `NEW_SURFACE` since the estimate last
      stated keeps that estimate: a view that adds no new surface never raises it.
    - A feature more than `REFUSE_RANGES` outside its training range (in units of the range):
      refused, naming the feature; less far: the std is multiplied by 1 + `WIDEN_PER_RANGE`
      times the distance.
    - A planner not among the fit's is named in `notes` (the estimate was measured less
      accurate on such a planner's views, and its widening covered them: the estimator's
      README).
    - An `UNEXPLORED` feature above the most the training views showed where the estimate
      claimed the goal (`TrainingDomain.claimed`): stated, but held back from a stop
      (`Stated.held`): a cavity no view has seen into looks like solid material to it.

    Args:
        estimator: The coverage estimator (its features include `occupied` and `acquired`).
        config: The run's configuration (its sensor is checked against the fit's).
        planner: The planner's name (`PLANNERS`, e.g. `uniform` for `uniform8`); None: not
            checked.

    Raises:
        ValueError: If the estimator's features lack `occupied` or `acquired`.
    """

    def __init__(self, estimator: CoverageEstimator, config: Config,
                 planner: str | None = None):
        missing = {"occupied", "acquired"} - set(estimator.features)
        if missing:
            raise ValueError(f"the estimate rule needs the features {sorted(missing)}")
        self.estimator = estimator
        self._occupied = estimator.features.index("occupied")
        self._acquired = estimator.features.index("acquired")
        self.notes: list[str] = []
        """Every note stated so far, once each, in order."""
        domain = estimator.domain
        self._refusal = None
        if domain is None:
            self._note("not checked for inputs unlike its training data: its file records no "
                       "training domain (format before 3)")
        elif domain.claimed is None:
            self._note("not checked for unexplored space beyond that of its claims in training: "
                       "its file records no limits (format before 4)")
        if domain is not None:
            mismatch = domain.sensor_mismatch(config.sensor)
            self._refusal = None if mismatch is None else f"not used: {mismatch}"
            if planner is not None and not any(
                    label == planner or (label.startswith(planner)
                                         and label[len(planner):].isdigit())
                    for label in domain.planners):
                self._note(f"may be less accurate: planner {planner!r} is not among those it "
                           f"was fit on ({', '.join(domain.planners)})")
        self.reset()

    def reset(self) -> None:
        """A new episode."""
        self._last: Stated | None = None
        self._last_occupied = 0.0

    def _note(self, note: str | None) -> None:
        if note is not None and note not in self.notes:
            self.notes.append(note)

    def update(self, features: np.ndarray) -> Stated:
        """The estimate after the next view, from its features (len(features),)."""
        x = np.asarray(features, dtype=float)
        occupied = float(x[self._occupied])
        if self._refusal is not None:
            stated = Stated(np.nan, np.nan, self._refusal)
        elif x[self._acquired] < 1:
            stated = Stated(np.nan, np.nan, "not made: no view acquired yet")
        elif self._last is not None and occupied * (1.0 - NEW_SURFACE) <= self._last_occupied:
            stated = dataclasses.replace(self._last, note=(
                f"kept: a view that grew the seen surface by less than {100 * NEW_SURFACE:g} % "
                f"keeps the estimate before it"))
        else:
            stated = self._fresh(x)
            self._last, self._last_occupied = stated, occupied
        if not stated.refused:
            stated = dataclasses.replace(stated, held=self._held(x))
        self._note(stated.note)
        self._note(stated.held)
        return stated

    def _held(self, x: np.ndarray) -> str | None:
        domain = self.estimator.domain
        column = domain.unexplored(x) if domain is not None else None
        if domain is None or domain.claimed is None or column is None:
            return None
        if domain.claimed[column] == -np.inf:
            # No percentile exists: `claim_limits` found no training view to take it over.
            return ("held back from every stop: on none of its training views did it claim the "
                    "goal, so nothing shows that a claim of it holds")
        return (f"held back from a stop: {self.estimator.features[column]} above "
                f"{domain.claimed[column]:.4g}, the {100 * CLAIM_QUANTILE:g}th percentile over "
                f"the training views on which it claimed the goal (space it was not shown to "
                f"judge)")

    def _fresh(self, x: np.ndarray) -> Stated:
        mean, std = (float(value) for value in self.estimator.estimate(x))
        domain = self.estimator.domain
        if domain is None:
            return Stated(mean, std)
        far = domain.outside(x)
        worst = int(np.argmax(far))
        if far[worst] == 0.0:
            return Stated(mean, std)
        where = (f"{self.estimator.features[worst]} outside its training range "
                 f"{domain.low[worst]:.4g} to {domain.high[worst]:.4g}")
        if far[worst] > REFUSE_RANGES:
            return Stated(np.nan, np.nan, f"not used: {where} by more than "
                                          f"{REFUSE_RANGES:g} of that range")
        return Stated(mean, std * (1.0 + WIDEN_PER_RANGE * float(far[worst])),
                      f"widened: {where}")
