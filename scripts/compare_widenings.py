"""Compare forms of the coverage estimate's widening for unseen families on the family folds.

Reads `family_folds.csv` of `vprobot stop fit` (each training family estimated by a fit without
it) and, for each form, fits the widening on four families' rows and checks it on the fifth, in
turn: the share of views within each stated interval level, the worst family's share within the
95 % interval, and the mean 95 % half-width. The forms: none; a scale on the std; a constant
added variance; an added variance per view count; a factor on the members' disagreement (the
one `stop fit` keeps). Each is fit, as `unseen_scale` is, as the least value whose widened 95 %
interval holds 95 % of the fitting rows.
"""

from __future__ import annotations

import argparse
import csv
from collections.abc import Callable
from pathlib import Path

import numpy as np

from vprobot.stop_studies.calibration import (
    LEVELS,
    UNSEEN_LEVEL,
    interval_coverage,
    least_holding,
    needed_variance,
    two_sided_z,
    unseen_scale,
)
from vprobot.stopping.estimator import widened_std

Rows = dict[str, np.ndarray]
Widening = Callable[[Rows], np.ndarray]


def fit_form(form: str, rows: Rows) -> Widening:
    """The widened std of a form, fit on `rows`."""
    needed = needed_variance(rows["mean"], rows["std"], rows["coverage"])
    if form == "none":
        return lambda new: new["std"]
    if form == "std scale":
        factor = max(least_holding(np.abs(rows["coverage"] - rows["mean"]) / rows["std"]
                                   / two_sided_z(UNSEEN_LEVEL)), 1.0)
        return lambda new: factor * new["std"]
    if form == "added variance":
        added = least_holding(needed)
        return lambda new: np.sqrt(new["std"] ** 2 + added)
    if form == "added variance per view count":
        last = int(rows["view"].max())
        per_view = np.array([least_holding(needed[rows["view"] == view])
                             for view in range(1, last + 1)])
        return lambda new: np.sqrt(new["std"] ** 2
                                   + per_view[np.clip(new["view"], 1, last).astype(int) - 1])
    factor = unseen_scale(rows["mean"], rows["std"], rows["disagreement"], rows["coverage"])
    return lambda new: widened_std(new["std"] ** 2, new["disagreement"], factor)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("folds", type=Path, help="family_folds.csv of `vprobot stop fit`")
    args = parser.parse_args()
    with args.folds.open(newline="") as stream:
        table = list(csv.DictReader(stream))
    rows = {name: np.array([float(row[name]) for row in table])
            for name in ("view", "coverage", "mean", "std", "disagreement")}
    rows["family"] = np.array([row["family"] for row in table])
    families = list(dict.fromkeys(rows["family"]))
    z = two_sided_z(UNSEEN_LEVEL)
    print("| widening | " + " | ".join(f"{100 * level:.0f} %" for level in LEVELS)
          + " | worst family 95 % | 95 % half-width pp |")
    print("|---" * (3 + len(LEVELS)) + "|")
    for form in ("none", "std scale", "added variance", "added variance per view count",
                 "disagreement factor"):
        held, worst, widths = np.zeros(len(LEVELS)), 1.0, []
        for family in families:
            out = rows["family"] == family
            std = fit_form(form, {name: value[~out] for name, value in rows.items()})(
                {name: value[out] for name, value in rows.items()})
            shares = interval_coverage(rows["mean"][out], std, rows["coverage"][out])
            held += shares * out.sum()
            worst = min(worst, shares[-1])
            widths.append(z * std)
        print(f"| {form} | " + " | ".join(f"{100 * share:.1f}" for share in held / len(table))
              + f" | {100 * worst:.1f} | {100 * np.concatenate(widths).mean():.2f} |")


if __name__ == "__main__":
    main()
