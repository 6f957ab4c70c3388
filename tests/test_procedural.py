"""The procedural family (vprobot.families.procedural): whole, varied, reproducible parts whose
cavity features hide surface inside the convex hull, and none of them a near-duplicate of a
held-out test object."""

from __future__ import annotations

import hashlib
from collections import Counter

import numpy as np
import pytest
import trimesh
from helpers import HELD_OUT_FAMILIES, HELD_OUT_SEEDS, likeness, shape_descriptor

from vprobot.cli import main
from vprobot.families import FAMILIES, family_rng
from vprobot.families.procedural import (
    CAVITY_KINDS,
    FEATURE_KINDS,
    Base,
    Layout,
    accepted_layout,
    base_of,
    draw_feature,
)

SEEDS = range(200)
FAMILY = FAMILIES["procedural"]
RADIUS_RANGE_M = (0.055, 0.16)
"""What every family keeps to (docs/episodes-and-carriers.md#part-families)."""


@pytest.fixture(scope="module")
def drawn() -> dict[int, tuple[Layout, trimesh.Trimesh]]:
    """The accepted layout and its mesh of every seed in SEEDS (about 3 s)."""
    return {seed: accepted_layout(FAMILY.sample(family_rng(FAMILY.name, seed)))
            for seed in SEEDS}


def hidden_area(mesh: trimesh.Trimesh) -> float:
    """Surface area (m^2) of the faces whose centre lies more than 10 um inside the convex
    hull: what no camera outside the hull sees head-on."""
    hull = mesh.convex_hull
    offsets = np.einsum("ij,ij->i", hull.face_normals, hull.triangles[:, 0])
    outside = (mesh.triangles_center @ hull.face_normals.T - offsets).max(axis=1)
    return float(mesh.area_faces[outside < -1e-5].sum())


def test_every_instance_is_one_closed_solid_centred_and_sized_like_the_families(
        drawn: dict[int, tuple[Layout, trimesh.Trimesh]]) -> None:
    for _, mesh in drawn.values():
        assert mesh.is_watertight and mesh.is_winding_consistent and mesh.volume > 0
        assert mesh.body_count == 1
        radius = np.linalg.norm(mesh.vertices - mesh.bounds.mean(axis=0), axis=1).max()
        assert RADIUS_RANGE_M[0] <= radius <= RADIUS_RANGE_M[1]
    for seed in SEEDS[:10]:
        instance = FAMILY.instance(seed)
        assert np.allclose(instance.mesh.bounds.mean(axis=0), 0, atol=1e-12)
        assert np.allclose(instance.mesh.vertices + drawn[seed][1].bounds.mean(axis=0),
                           drawn[seed][1].vertices)


def test_the_seed_fixes_the_part_and_every_seed_gives_another(
        drawn: dict[int, tuple[Layout, trimesh.Trimesh]]) -> None:
    digests = {hashlib.sha256(mesh.vertices.tobytes()).hexdigest() for _, mesh in drawn.values()}
    assert len(digests) == len(SEEDS)
    # Drawn again after every other seed, and rebuilt from its recorded parameters alone.
    instance = FAMILY.instance(17)
    assert np.array_equal(FAMILY.build(instance.parameters).vertices, drawn[17][1].vertices)
    assert FAMILY.instance(17).mesh.export(file_type="stl") == instance.mesh.export(
        file_type="stl")


def test_the_base_body_has_the_drawn_bounding_sphere_radius() -> None:
    for seed in range(30):
        values = FAMILY.sample(family_rng(FAMILY.name, seed))
        base = base_of(values)
        radius = np.linalg.norm(base.mesh().vertices, axis=1).max()
        assert radius == pytest.approx(values["size_m"], rel=1e-9)
        assert base.size == pytest.approx(radius, rel=1e-9)


def test_every_feature_kind_and_base_kind_appears_across_seeds(
        drawn: dict[int, tuple[Layout, trimesh.Trimesh]]) -> None:
    kinds = Counter(feature.kind for layout, _ in drawn.values() for feature in layout.features)
    assert set(kinds) == set(FEATURE_KINDS)
    assert min(kinds.values()) >= 50
    assert {layout.base.kind for layout, _ in drawn.values()} == {"plate", "block", "disc"}
    counts = Counter(len(layout.features) for layout, _ in drawn.values())
    assert set(counts) == set(range(2, 9))


@pytest.mark.parametrize("kind", CAVITY_KINDS)
def test_a_cavity_feature_makes_surface_inside_the_convex_hull(kind: str) -> None:
    base = Base("block", (0.16, 0.12, 0.07))
    assert hidden_area(base.mesh()) == 0.0
    for seed in range(5):
        feature = draw_feature(kind, np.random.default_rng(seed), base, base.flat_faces()[0])
        mesh = Layout(base, (feature,)).mesh()
        assert mesh.is_volume and mesh.body_count == 1
        assert hidden_area(mesh) > 1e-5, (kind, seed)  # > 10 mm^2


def test_instances_with_cavity_features_hide_part_of_their_surface(
        drawn: dict[int, tuple[Layout, trimesh.Trimesh]]) -> None:
    fractions = [hidden_area(mesh) / mesh.area for layout, mesh in drawn.values()
                 if {f.kind for f in layout.features} & set(CAVITY_KINDS)]
    assert len(fractions) > 0.9 * len(SEEDS)
    assert min(fractions) > 0.0
    assert np.median(fractions) > 0.05


def test_no_instance_is_a_near_duplicate_of_a_held_out_test_object(
        drawn: dict[int, tuple[Layout, trimesh.Trimesh]],
        held_out_descriptors: list[tuple[np.ndarray, ...]]) -> None:
    # Near-duplicates are pairs below 1 (`likeness`). Measured with this descriptor: a test
    # object turned and scaled by 1.1 is at 0.68 at most (caught); among 48 seeds of each test
    # family, 8 % (bracket) to 56 % (valve_body) of the instances have a sibling below 1; the
    # first 20 instances of every training family stay above 2.1, and procedural seeds 0-299
    # above 1.7 against those 48 seeds and the shapes (2.06 for the seeds and objects here).
    held_out = held_out_descriptors  # of helpers' held_out_test_objects(), in order
    copy = FAMILIES[HELD_OUT_FAMILIES[0]].instance(HELD_OUT_SEEDS[0]).mesh.copy()  # the first
    copy.apply_transform(trimesh.transformations.rotation_matrix(1.0, (1, 2, 3)))
    copy.apply_scale(1.1)
    assert likeness(shape_descriptor(copy), held_out[0]) < 1
    procedural = [shape_descriptor(mesh) for _, mesh in drawn.values()]
    closest = min(likeness(one, other) for one in procedural for other in held_out)
    assert closest > 1


def test_objects_list_shows_the_procedural_family(capsys: pytest.CaptureFixture) -> None:
    assert main(["objects", "list"]) == 0
    out = capsys.readouterr().out
    assert f"procedural: {FAMILY.description}" in out
    assert "feature_count" in out and "2 .. 8" in out
