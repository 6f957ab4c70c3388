"""Part families (vprobot.families): closed, fitting the cell, reproducible from the seed, and
the `vprobot objects` command."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from vprobot.cell.fit import check_fits
from vprobot.cli import main
from vprobot.config import Config
from vprobot.families import FAMILIES, family_rng
from vprobot.parts.generated import VERSION
from vprobot.parts.loading import load_mesh

RADIUS_RANGE_M = (0.055, 0.16)
"""Neither tiny in the cell nor at its limit (0.189 m with the default config)."""


def _stl(name: str, seed: int) -> bytes:
    return FAMILIES[name].instance(seed).mesh.export(file_type="stl")


def test_there_are_at_least_eight_families() -> None:
    assert len(FAMILIES) >= 8
    assert all(name == part.name for name, part in FAMILIES.items())


@pytest.mark.parametrize("name", sorted(FAMILIES))
def test_instances_are_closed_solids_that_fit_the_cell(name: str, tmp_path: Path) -> None:
    for seed in (0, 1):
        path = tmp_path / f"{seed}.stl"
        path.write_bytes(_stl(name, seed))
        loaded = load_mesh(path)  # re-read from the file, as an episode would
        assert loaded.mesh.is_watertight and loaded.mesh.volume > 0
        assert loaded.mesh.body_count == 1
        check_fits(loaded, Config())
        radius = np.linalg.norm(loaded.mesh.vertices, axis=1).max()
        assert RADIUS_RANGE_M[0] <= radius <= RADIUS_RANGE_M[1]


@pytest.mark.parametrize("name", sorted(FAMILIES))
def test_same_seed_gives_the_same_stl_bytes_and_another_seed_differs(name: str) -> None:
    first = _stl(name, 5)
    assert _stl(name, 5) == first
    assert _stl(name, 6) != first


@pytest.mark.parametrize("name", sorted(FAMILIES))
def test_drawn_parameters_lie_in_their_listed_ranges(name: str) -> None:
    part = FAMILIES[name]
    for seed in range(20):
        values = part.sample(family_rng(name, seed))
        assert list(values) == [p.name for p in part.parameters]
        for p in part.parameters:
            assert p.low <= values[p.name] <= p.high
            assert isinstance(values[p.name], int) == p.integer


def test_the_random_stream_is_fixed_by_family_name_and_seed() -> None:
    # sha256("flange")[:4] as a little-endian integer is the spawn key: a salted hash() or
    # another key would change every instance; the value is numpy's for that seed sequence.
    expected = np.random.default_rng(np.random.SeedSequence(3, spawn_key=(
        int.from_bytes(bytes.fromhex("653fc760"), "little"),))).random()
    assert family_rng("flange", 3).random() == expected
    assert family_rng("pulley", 3).random() != expected


def test_objects_list_names_every_family_and_parameter(capsys: pytest.CaptureFixture) -> None:
    assert main(["objects", "list"]) == 0
    out = capsys.readouterr().out
    for name, part in FAMILIES.items():
        assert f"{name}: {part.description}" in out
        for p in part.parameters:
            assert p.name in out and p.range_text() in out


def test_objects_generate_writes_count_instances_from_the_seed(tmp_path: Path) -> None:
    out = tmp_path / "parts"
    assert main(["objects", "generate", "--family", "lever", "--count", "2", "--seed", "7",
                 "--out", str(out)]) == 0
    assert sorted(p.name for p in out.iterdir()) == [
        "lever_0007.json", "lever_0007.stl", "lever_0008.json", "lever_0008.stl"]
    assert (out / "lever_0008.stl").read_bytes() == _stl("lever", 8)
    meta = json.loads((out / "lever_0007.json").read_text())
    assert meta == {"family": "lever", "seed": 7,
                    "parameters": FAMILIES["lever"].instance(7).parameters}


def test_unknown_family_is_one_line_listing_the_families(
        tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    with pytest.raises(SystemExit) as exit_info:
        main(["objects", "generate", "--family", "gear", "--count", "1", "--out",
              str(tmp_path / "parts")])
    error = capsys.readouterr().err
    assert exit_info.value.code == 2 and len(error.strip().splitlines()) == 1
    assert "'gear'" in error and ", ".join(FAMILIES) in error
    assert not (tmp_path / "parts").exists()


def test_objects_benchmark_times_new_instances_and_extrapolates_to_the_split(
        monkeypatch: pytest.MonkeyPatch) -> None:
    import vprobot.benchmarks.objects as benchmark

    monkeypatch.setattr(benchmark, "FAMILIES", {"lever": FAMILIES["lever"]})
    results = benchmark.run_objects_benchmark(Config(), per_family=1, progress=False)
    assert set(results["build_s"]) == set(results["ground_truth_s"]) == {"lever", "motor"}
    assert all(value > 0 for value in results["ground_truth_s"].values())
    assert results["split_training_instances"] == 5 * 200
    assert results["split_training_hours"] == pytest.approx(
        1000 * results["instance_s_median"] / 3600)


def test_objects_cache_builds_every_training_object_and_its_ground_truth(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    import dataclasses

    from vprobot.files.paths import CACHE_ENV_VAR
    from vprobot.parts.splits import Split

    split = dataclasses.replace(Split.load(), training_instances=range(2))
    monkeypatch.setattr(Split, "load", classmethod(lambda cls, path=None: split))
    monkeypatch.setenv(CACHE_ENV_VAR, str(tmp_path / "cache"))
    profile = tmp_path / "profile.yaml"
    profile.write_text("env:\n  objects: [lever]\n")
    assert main(["objects", "cache", str(profile)]) == 0
    made = sorted(path.name for path in (tmp_path / "cache" / "objects").rglob("*.stl"))
    assert made == ["lever_0000.stl", "lever_0001.stl"]
    assert len(list((tmp_path / "cache" / "ground_truth").glob("*.npz"))) == 2


def _levers(tmp_path: Path, monkeypatch: pytest.MonkeyPatch, count: int) -> Path:
    """A profile training on `count` instances of the lever family (lever_0000, ...), the
    cache in tmp_path/cache."""
    import dataclasses

    from vprobot.files.paths import CACHE_ENV_VAR
    from vprobot.parts.splits import Split

    split = dataclasses.replace(Split.load(), training_instances=range(count))
    monkeypatch.setattr(Split, "load", classmethod(lambda cls, path=None: split))
    monkeypatch.setenv(CACHE_ENV_VAR, str(tmp_path / "cache"))
    profile = tmp_path / "profile.yaml"
    profile.write_text("env:\n  objects: [lever]\n")
    return profile


def test_a_cached_object_cut_short_is_built_again(tmp_path: Path,
                                                   monkeypatch: pytest.MonkeyPatch) -> None:
    whole = FAMILIES["lever"].instance(0).mesh.export(file_type="stl")
    profile = _levers(tmp_path, monkeypatch, 1)
    cached = tmp_path / "cache" / "objects" / f"v{VERSION}" / "lever_0000.stl"
    cached.parent.mkdir(parents=True)
    cached.write_bytes(whole[: len(whole) // 2])
    assert main(["objects", "cache", str(profile)]) == 0
    assert cached.read_bytes() == whole


def test_a_read_only_cache_warns_once_and_the_run_goes_on(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
        capsys: pytest.CaptureFixture[str]) -> None:
    import errno
    import tempfile

    profile = _levers(tmp_path, monkeypatch, 2)
    cache = tmp_path / "cache"
    mkstemp = tempfile.mkstemp

    def read_only(*args: object, dir: str | None = None, **kwargs: object) -> tuple[int, str]:
        # As a read-only file system refuses it (root would write into a chmod 500 folder).
        if dir is not None and Path(dir).is_relative_to(cache):
            raise OSError(errno.EROFS, "Read-only file system", dir)
        return mkstemp(*args, dir=dir, **kwargs)

    monkeypatch.setattr(tempfile, "mkstemp", read_only)
    assert main(["objects", "cache", str(profile)]) == 0
    err = capsys.readouterr().err
    assert err.count("generated-objects cache") == 1
    assert (f"vprobot objects cache: warning: cannot write the generated-objects cache "
            f"{cache / 'objects' / f'v{VERSION}'} ([Errno 30] Read-only file system") in err
    assert not list(cache.rglob("*.stl"))


def test_objects_generate_bundled_rewrites_the_committed_objects_byte_for_byte(
        tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    from vprobot.files.paths import OBJECTS_DIR

    assert main(["objects", "generate", "--bundled", "--out", str(tmp_path)]) == 0
    committed = sorted(path.name for path in OBJECTS_DIR.glob("*.stl"))
    assert sorted(path.name for path in tmp_path.iterdir()) == committed == [
        "bracket.stl", "pipe_tee.stl", "torus.stl"]
    assert all((tmp_path / name).read_bytes() == (OBJECTS_DIR / name).read_bytes()
               for name in committed)
    assert capsys.readouterr().out == f"wrote 3 objects to {tmp_path}\n"


BUNDLED_ONLY = ("--bundled writes the bundled objects (bracket, pipe_tee, torus); --family, "
                "--count and --seed are not allowed with it")


@pytest.mark.parametrize(("argv", "message"), [
    (["--bundled", "--family", "lever"], BUNDLED_ONLY),
    (["--bundled", "--count", "2"], BUNDLED_ONLY),
    (["--family", "lever", "--out", "parts"],
     "--family, --count and --out are required (or --bundled)"),
])
def test_objects_generate_refuses_mixed_or_missing_options_in_one_line(
        argv: list[str], message: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
        capsys: pytest.CaptureFixture) -> None:
    monkeypatch.chdir(tmp_path)
    assert main(["objects", "generate", *argv]) == 2
    assert capsys.readouterr().err == f"vprobot objects generate: error: {message}\n"
    assert list(tmp_path.iterdir()) == []
