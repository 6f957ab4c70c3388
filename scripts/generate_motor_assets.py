"""Regenerate the committed starter-motor set: assets/motors/{train,test}/."""

from __future__ import annotations

from vprobot.motors import generate_motors
from vprobot.paths import MOTORS_DIR

# (split, count, seed); the paper's 100 motors are `--count 100 --seed 0`, so train is a prefix.
SPLITS = [("train", 20, 0), ("test", 5, 1)]


def main() -> None:
    """Write every split, replacing files of the same name."""
    for split, count, seed in SPLITS:
        for index, stl in enumerate(generate_motors(count, seed, MOTORS_DIR / split)):
            # The bundled motors keep the names the episode lists and splits give them
            # (`test/motor_000.stl`), from before files were named by their set's seed.
            for path in (stl, stl.with_suffix(".json")):
                path.replace(path.with_stem(f"motor_{index:03d}"))


if __name__ == "__main__":
    main()
