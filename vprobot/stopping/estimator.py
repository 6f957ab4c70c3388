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
intervals hold on families left out of the fit in turn (`vprobot.stopping.folds`,
`vprobot.stopping.calibration.unseen_scale`): the uncertainty stated for any part is the one
that held on families the estimate had not seen, and it grows where the members disagree (on
unfamiliar inputs) rather than everywhere.

Training uses torch; `estimate` is plain numpy, so that a stop rule needs neither torch nor a
pickle: the weights are stored as arrays in an `.npz` file.
"""

from __future__ import annotations

import dataclasses
import functools
import itertools
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from vprobot.files import atomic_output
from vprobot.paths import ESTIMATOR_DIR

MEMBERS = 5
HIDDEN = 32
STEPS = 3000
CHECK_EVERY = 25
"""Steps between validation checks (early stopping: the best checked weights are kept)."""
LEARNING_RATE = 3e-3
WEIGHT_DECAY = 1e-4
MIN_STD = 1e-3
"""Floor of a member's stated standard deviation (coverage is known to no better anyway)."""
FORMAT = 2
"""Format 2 adds the widening for unseen families; format 1 files load without one."""
BUNDLED_ESTIMATOR = ESTIMATOR_DIR / "estimator.npz"
"""The estimator `--stop estimate` uses unless told otherwise (its README says how it was fit)."""


def widened_std(variance: np.ndarray, disagreement: np.ndarray,
                unseen_scale: float) -> np.ndarray:
    """The standard deviation an estimate states: its mixture's variance plus `unseen_scale`
    times the members' disagreement (`CoverageEstimator.mixture`), at least `MIN_STD`."""
    return np.sqrt(np.maximum(variance + unseen_scale * disagreement, MIN_STD ** 2))


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

    Raises:
        ValueError: For a negative or infinite `unseen_scale`.
    """

    features: tuple[str, ...]
    shift: np.ndarray
    scale: np.ndarray
    layers: tuple[tuple[tuple[np.ndarray, np.ndarray], ...], ...]
    unseen_scale: float = 0.0

    def __post_init__(self) -> None:
        if not 0.0 <= self.unseen_scale < np.inf:
            raise ValueError(f"unseen_scale must be finite and >= 0, got {self.unseen_scale}")

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
        for m, member in enumerate(self.layers):
            for k, (weight, bias) in enumerate(member):
                arrays[f"w_{m}_{k}"], arrays[f"b_{m}_{k}"] = weight, bias
        with atomic_output(path) as temporary:
            with temporary.open("wb") as stream:
                np.savez(stream, **arrays)  # type: ignore[arg-type]
        return path

    @classmethod
    def load(cls, path: str | Path) -> CoverageEstimator:
        """Read an estimator written by `save`.

        Raises:
            ValueError: If the file is missing or not an estimator of this format.
        """
        try:
            with np.load(Path(path), allow_pickle=False) as data:
                version = int(data["format"])
                if version not in (1, FORMAT):
                    raise ValueError(f"{path}: estimator format {version}, expected 1 to "
                                     f"{FORMAT}")
                members, depth = (int(n) for n in data["shape"])
                layers = tuple(tuple((data[f"w_{m}_{k}"], data[f"b_{m}_{k}"])
                                     for k in range(depth)) for m in range(members))
                unseen = float(data["unseen_scale"]) if version >= 2 else 0.0
                return cls(tuple(str(name) for name in data["features"]), data["shift"],
                           data["scale"], layers, unseen)
        except (OSError, KeyError, ValueError) as error:
            raise ValueError(f"cannot read coverage estimator {path}: {error}") from None


def load_estimator(path: str | Path | None = None) -> CoverageEstimator:
    """The estimator of an `.npz` file of `vprobot stop fit`, or the bundled one (None).

    Raises:
        ValueError: If the file is missing or not an estimator.
    """
    shown = Path(path) if path is not None else BUNDLED_ESTIMATOR
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
