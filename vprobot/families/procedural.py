"""Procedural parts: random constructive solids beyond the named families (issue 34).

An instance is a base body (a plate, a block or a disc) with a random list of features drawn
from a vocabulary (`FEATURE_KINDS`): pads (a block standing on a face), bosses (half of them
bored), ribs (straight or gusset), through holes, blind holes, pockets, slots, steps cut along
an edge, overhangs (a shelf on a post with a gap under it) and undercuts (a T-slot, wider below
than at the surface). The top-level knobs are parameters; the features are drawn inside `build`
from a generator seeded by the `layout_seed` parameter, so (family, seed) fixes the part and its
JSON rebuilds it. A draw that does not give one closed solid within `RADIUS_RANGE_M` is drawn
again from the same generator, so that redraws are reproducible too."""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from typing import Protocol, TypeVar

import numpy as np
import trimesh

from vprobot.families.base import Parameter, PartFamily, Values, register_family
from vprobot.families.solids import OVERLAP_M, box, carve, hull, rod

BASE_KINDS = ("plate", "block", "disc")
HEIGHT_RANGES = {"plate": (0.05, 0.12), "block": (0.3, 0.7), "disc": (0.12, 0.7)}
"""Height / length (disc: height / diameter) of each base kind, from `height_ratio` 0 to 1."""
CAVITY_KINDS = ("through_hole", "blind_hole", "pocket", "slot", "step", "overhang", "undercut")
"""Features that leave surface inside the part's convex hull, which a camera must look into."""
RADIUS_RANGE_M = (0.06, 0.155)
"""Bounding-sphere radius of every instance: inside the 0.055-0.16 m that every family keeps to
(docs/episodes-and-carriers.md#part-families; the default cell allows 0.189 m)."""
MAX_DRAWS = 50
"""Layouts drawn before a seed is given up on, a bug of a drawer (of seeds 0-4999, 1 in 10 takes
a second draw and none more than 9)."""
_MIN_FACE_M = 0.01
"""Faces narrower than twice this (a plate's edges) take no features."""
_SECTIONS = 40


@dataclasses.dataclass(frozen=True)
class Face:
    """Where features go: a face of the base in a right-handed frame (u, v, normal).

    Attributes:
        origin: Centre of the face (on the disc's side: where its tangent plane touches).
        normal: Outward normal.
        u: First in-plane axis.
        v: Second in-plane axis, normal x u.
        half: Half extents along u and v of where features are placed.
        reach: Half extents along u and v of the body (steps and T-slots run out past them).
        depth: Material behind the face along -normal.
        curvature_radius: Radius of the disc's side, 0 for a flat face.
    """

    origin: np.ndarray
    normal: np.ndarray
    u: np.ndarray
    v: np.ndarray
    half: tuple[float, float]
    reach: tuple[float, float]
    depth: float
    curvature_radius: float = 0.0

    def frame(self, s: float, t: float, w: float) -> np.ndarray:
        """Pose (4 x 4) of local point (s, t, w), axes (u, v, normal)."""
        pose = np.eye(4)
        pose[:3, :3] = np.column_stack([self.u, self.v, self.normal])
        pose[:3, 3] = self.origin + s * self.u + t * self.v + w * self.normal
        return pose

    def point(self, s: float, t: float, w: float) -> np.ndarray:
        return self.frame(s, t, w)[:3, 3]

    def box(self, extents: tuple[float, float, float], centre: tuple[float, float, float],
            ) -> trimesh.Trimesh:
        """A box of local `extents` (along u, v, normal) centred at local `centre`."""
        return trimesh.creation.box(extents=extents, transform=self.frame(*centre))

    def sag(self, s: float) -> float:
        """How far the curved side lies below the tangent plane `s` off its centre line:
        additive features reach that much deeper to meet it."""
        r = self.curvature_radius
        return 0.0 if r == 0 else r - float(np.sqrt(max(r * r - s * s, 0.0)))


@dataclasses.dataclass(frozen=True)
class Feature:
    """One drawn feature: what it adds and what it cuts away."""

    kind: str
    solids: tuple[trimesh.Trimesh, ...] = ()
    cuts: tuple[trimesh.Trimesh, ...] = ()


@dataclasses.dataclass(frozen=True)
class Base:
    """The base body, centred at the origin, and its faces.

    Attributes:
        kind: One of `BASE_KINDS`.
        extents: Bounding-box size (x, y, z); a disc's axis is z.
    """

    kind: str
    extents: tuple[float, float, float]

    @property
    def size(self) -> float:
        """Bounding-sphere radius (the `size_m` parameter): the scale features are drawn at."""
        if self.kind == "disc":
            return float(np.hypot(self.extents[0], self.extents[2])) / 2
        return float(np.linalg.norm(self.extents)) / 2

    def mesh(self) -> trimesh.Trimesh:
        if self.kind == "disc":
            half = self.extents[2] / 2
            return rod(self.extents[0] / 2, (0, 0, -half), (0, 0, half), 96)
        return box(self.extents)

    def flat_faces(self) -> list[Face]:
        """The faces that take features, top and bottom first (a disc: top and bottom)."""
        extents = np.asarray(self.extents)
        axes = np.eye(3)
        faces = []
        for axis in ((2, 0, 1), (0, 1, 2), (1, 2, 0))[: 1 if self.kind == "disc" else 3]:
            n_axis, u_axis, v_axis = axis
            for sign in (1, -1):
                normal = sign * axes[n_axis]
                u = axes[u_axis]
                half = (extents[u_axis] / 2, extents[v_axis] / 2)
                if self.kind == "disc":  # the square inscribed in the circle
                    placed = (half[0] / np.sqrt(2), half[1] / np.sqrt(2))
                else:
                    placed = half
                faces.append(Face(normal * extents[n_axis] / 2, normal, u,
                                  np.cross(normal, u), placed, half, float(extents[n_axis])))
        return [face for face in faces if min(face.half) >= _MIN_FACE_M]

    def side_face(self, angle: float) -> Face:
        """The disc's side where it faces `angle` (rad about z), as its tangent plane."""
        radius, height = self.extents[0] / 2, self.extents[2]
        normal = np.array([np.cos(angle), np.sin(angle), 0.0])
        u = np.array([-np.sin(angle), np.cos(angle), 0.0])
        return Face(radius * normal, normal, u, np.cross(normal, u), (0.5 * radius, height / 2),
                    (0.5 * radius, height / 2), 2 * radius, radius)

    def draw_face(self, rng: np.random.Generator) -> Face:
        """A face for the next feature: the top half of the time, else any other."""
        faces = self.flat_faces()
        if rng.random() < 0.5:
            return faces[0]
        if self.kind == "disc" and self.extents[2] >= 2 * _MIN_FACE_M and rng.random() < 0.6:
            return self.side_face(float(rng.uniform(0, 2 * np.pi)))
        return faces[int(rng.integers(1, len(faces)))]


def base_of(values: Values) -> Base:
    """The base body that the top-level parameters set."""
    kind = BASE_KINDS[int(values["base_kind"])]
    low, high = HEIGHT_RANGES[kind]
    height = low + values["height_ratio"] * (high - low)
    size = values["size_m"]
    if kind == "disc":
        diameter = 2 * size / np.hypot(1, height)
        return Base(kind, (diameter, diameter, height * diameter))
    length = 2 * size / np.sqrt(1 + values["width_ratio"] ** 2 + height**2)
    return Base(kind, (length, values["width_ratio"] * length, height * length))


def _place(rng: np.random.Generator, face: Face, footprint: tuple[float, float],
           ) -> tuple[float, float]:
    """A position on the face that keeps a footprint of these half extents on it."""
    s, t = (float(rng.uniform(-1, 1)) * max(h - f, 0.0)
            for h, f in zip(face.half, footprint, strict=True))
    return s, t


def _clip(value: float, low: float, high: float) -> float:
    return float(np.clip(value, low, high))


def _pad(rng: np.random.Generator, face: Face, size: float) -> Feature:
    footprint = (max(rng.uniform(0.25, 0.7) * face.half[0], 0.006),
                 max(rng.uniform(0.25, 0.7) * face.half[1], 0.006))
    height = rng.uniform(0.2, 0.6) * size
    s, t = _place(rng, face, footprint)
    low = -OVERLAP_M - face.sag(abs(s) + footprint[0])
    extents = (2 * footprint[0], 2 * footprint[1], height - low)
    return Feature("pad", (face.box(extents, (s, t, (height + low) / 2)),))


def _boss(rng: np.random.Generator, face: Face, size: float) -> Feature:
    radius = _clip(rng.uniform(0.15, 0.45) * min(face.half), 0.004, 0.04)
    height = rng.uniform(0.15, 0.5) * size
    s, t = _place(rng, face, (radius, radius))
    start = face.point(s, t, -OVERLAP_M - face.sag(abs(s) + radius))
    solids = (rod(radius, start, face.point(s, t, height), _SECTIONS),)
    if rng.random() < 0.5:
        bore = rng.uniform(0.35, 0.65) * radius
        bottom = height * (1 - rng.uniform(0.5, 0.9))
        cuts = (rod(bore, face.point(s, t, bottom), face.point(s, t, height + OVERLAP_M),
                    _SECTIONS),)
        return Feature("boss", solids, cuts)
    return Feature("boss", solids)


def _rib(rng: np.random.Generator, face: Face, size: float) -> Feature:
    along = int(rng.integers(2))
    length = rng.uniform(0.4, 0.9) * 2 * face.half[along]
    thickness = _clip(rng.uniform(0.03, 0.08) * size, 0.003, 0.01)
    height = rng.uniform(0.15, 0.45) * size
    footprint = (length / 2, thickness / 2) if along == 0 else (thickness / 2, length / 2)
    s, t = _place(rng, face, footprint)
    low = -OVERLAP_M - face.sag(abs(s) + footprint[0])
    if rng.random() < 0.5:
        extents = (2 * footprint[0], 2 * footprint[1], height - low)
        return Feature("rib", (face.box(extents, (s, t, (height + low) / 2)),))
    # A gusset: a triangle, full height at one end of the rib and nothing at the other.
    ends = np.array([-1.0, 1.0]) * length / 2 * rng.choice((-1, 1))
    corners = [(ends[0], low), (ends[1], low), (ends[0], height)]
    points = []
    for a, w in corners:
        for b in (-thickness / 2, thickness / 2):
            local = (s + a, t + b) if along == 0 else (s + b, t + a)
            points.append(face.point(local[0], local[1], w))
    return Feature("rib", (hull(np.array(points)),))


def _hole(rng: np.random.Generator, face: Face, size: float, through: bool) -> Feature:
    radius = _clip(rng.uniform(0.1, 0.3) * min(face.half), 0.002, 0.02)
    s, t = _place(rng, face, (radius, radius))
    depth = face.depth + OVERLAP_M if through else rng.uniform(0.3, 0.7) * face.depth
    kind = "through_hole" if through else "blind_hole"
    return Feature(kind, cuts=(rod(radius, face.point(s, t, OVERLAP_M),
                                   face.point(s, t, -depth - face.sag(abs(s))), _SECTIONS),))


def _through_hole(rng: np.random.Generator, face: Face, size: float) -> Feature:
    return _hole(rng, face, size, through=True)


def _blind_hole(rng: np.random.Generator, face: Face, size: float) -> Feature:
    return _hole(rng, face, size, through=False)


def _pocket(rng: np.random.Generator, face: Face, size: float) -> Feature:
    footprint = (_clip(rng.uniform(0.2, 0.6) * face.half[0], 0.004, 0.06),
                 _clip(rng.uniform(0.2, 0.6) * face.half[1], 0.004, 0.06))
    s, t = _place(rng, face, footprint)
    depth = min(rng.uniform(0.25, 0.6) * face.depth, 0.04) + face.sag(abs(s) + footprint[0])
    extents = (2 * footprint[0], 2 * footprint[1], depth + OVERLAP_M)
    return Feature("pocket", cuts=(face.box(extents, (s, t, (OVERLAP_M - depth) / 2)),))


def _slot(rng: np.random.Generator, face: Face, size: float) -> Feature:
    along = int(rng.integers(2))
    width = _clip(rng.uniform(0.1, 0.3) * min(face.half), 0.003, 0.02)
    length = max(rng.uniform(0.3, 0.7) * 2 * face.half[along], 2 * width)
    footprint = (length / 2, width / 2) if along == 0 else (width / 2, length / 2)
    s, t = _place(rng, face, footprint)
    through = rng.random() < 0.5
    depth = face.depth + OVERLAP_M if through else rng.uniform(0.3, 0.7) * face.depth
    depth += face.sag(abs(s) + footprint[0])
    straight = (2 * footprint[0] - (width if along == 0 else 0),
                2 * footprint[1] - (width if along == 1 else 0), depth + OVERLAP_M)
    cuts = [face.box(straight, (s, t, (OVERLAP_M - depth) / 2))]
    for end in (-1, 1):
        offset = end * (length - width) / 2
        centre = (s + offset, t) if along == 0 else (s, t + offset)
        cuts.append(rod(width / 2, face.point(*centre, OVERLAP_M), face.point(*centre, -depth),
                        _SECTIONS))
    return Feature("slot", cuts=tuple(cuts))


def _step(rng: np.random.Generator, face: Face, size: float) -> Feature:
    along = int(rng.integers(2))  # the step runs along this axis, its edge on the other
    across, side = 1 - along, float(rng.choice((-1, 1)))
    reach = face.reach
    width = rng.uniform(0.15, 0.4) * 2 * reach[across]
    depth = rng.uniform(0.2, 0.5) * face.depth
    extents = [0.0, 0.0, depth + OVERLAP_M]
    centre = [0.0, 0.0, (OVERLAP_M - depth) / 2]
    extents[along] = 2 * (reach[along] + OVERLAP_M)
    extents[across] = width + OVERLAP_M
    centre[across] = side * (reach[across] - width / 2 + OVERLAP_M / 2)
    return Feature("step", cuts=(face.box((extents[0], extents[1], extents[2]),
                                          (centre[0], centre[1], centre[2])),))


def _overhang(rng: np.random.Generator, face: Face, size: float) -> Feature:
    post = (rng.uniform(0.08, 0.2) * face.half[0], rng.uniform(0.08, 0.2) * face.half[1])
    post = (max(post[0], 0.003), max(post[1], 0.003))
    gap = rng.uniform(0.15, 0.35) * size
    shelf = _clip(rng.uniform(0.03, 0.06) * size, 0.003, 0.008)
    reach = rng.uniform(1.5, 4.0) * post[0]  # how far the shelf juts out past the post
    side = float(rng.choice((-1, 1)))
    s, t = _place(rng, face, (post[0] + reach, post[1] * 1.5))
    solids = (face.box((2 * post[0], 2 * post[1], gap + OVERLAP_M),
                       (s, t, (gap - OVERLAP_M) / 2)),
              face.box((2 * post[0] + reach, 3 * post[1], shelf + OVERLAP_M),
                       (s + side * reach / 2, t, gap + (shelf - OVERLAP_M) / 2)))
    return Feature("overhang", solids)


def _undercut(rng: np.random.Generator, face: Face, size: float) -> Feature:
    along = int(rng.integers(2))  # the T-slot runs through the part along this axis
    across = 1 - along
    neck = _clip(rng.uniform(0.08, 0.18) * 2 * face.half[across], 0.003, 0.015)
    channel = rng.uniform(1.8, 3.0) * neck
    neck_depth = rng.uniform(0.1, 0.25) * face.depth
    channel_depth = rng.uniform(0.15, 0.3) * face.depth
    offset = float(rng.uniform(-1, 1)) * max(face.half[across] - channel / 2, 0.0)
    cuts = []
    for width, top, bottom in ((neck, OVERLAP_M, -neck_depth - OVERLAP_M),
                               (channel, -neck_depth, -neck_depth - channel_depth)):
        extents = [0.0, 0.0, top - bottom]
        centre = [0.0, 0.0, (top + bottom) / 2]
        extents[along] = 2 * (face.reach[along] + OVERLAP_M)
        extents[across], centre[across] = width, offset
        cuts.append(face.box((extents[0], extents[1], extents[2]),
                             (centre[0], centre[1], centre[2])))
    return Feature("undercut", cuts=tuple(cuts))


FeatureDrawer = Callable[[np.random.Generator, Face, float], Feature]
DRAWERS: dict[str, FeatureDrawer] = {
    "pad": _pad, "boss": _boss, "rib": _rib, "through_hole": _through_hole,
    "blind_hole": _blind_hole, "pocket": _pocket, "slot": _slot, "step": _step,
    "overhang": _overhang, "undercut": _undercut}
"""How each feature kind is drawn on a face, at the base's scale."""
FEATURE_KINDS = tuple(DRAWERS)
_FLAT_ONLY = ("step", "overhang", "undercut")


def draw_feature(kind: str, rng: np.random.Generator, base: Base, face: Face) -> Feature:
    """A feature of `kind` on `face` of `base`."""
    return DRAWERS[kind](rng, face, base.size)


@dataclasses.dataclass(frozen=True)
class Layout:
    """A drawn part: its base and features, and the mesh they make."""

    base: Base
    features: tuple[Feature, ...]

    def mesh(self) -> trimesh.Trimesh:
        solids = [self.base.mesh(), *(s for f in self.features for s in f.solids)]
        return carve(solids, [c for f in self.features for c in f.cuts])


def draw_layout(values: Values, rng: np.random.Generator) -> Layout:
    """A base and `feature_count` features, each of a uniform kind on a drawn face."""
    base = base_of(values)
    features = []
    for _ in range(int(values["feature_count"])):
        face = base.draw_face(rng)
        kinds = FEATURE_KINDS if face.curvature_radius == 0 else [
            kind for kind in FEATURE_KINDS if kind not in _FLAT_ONLY]
        features.append(draw_feature(str(rng.choice(kinds)), rng, base, face))
    return Layout(base, tuple(features))


def is_whole(mesh: trimesh.Trimesh) -> bool:
    """One closed, consistently wound solid of positive volume within `RADIUS_RANGE_M`."""
    if not (mesh.is_volume and mesh.body_count == 1):
        return False
    radius = np.linalg.norm(mesh.vertices - mesh.bounds.mean(axis=0), axis=1).max()
    return bool(RADIUS_RANGE_M[0] <= radius <= RADIUS_RANGE_M[1])


class NoRoom(Exception):
    """A drawn feature found no place on the part: the layout is drawn again."""


class DrawnLayout(Protocol):
    """A drawn part that makes its mesh."""

    def mesh(self) -> trimesh.Trimesh: ...


L = TypeVar("L", bound=DrawnLayout)


def first_whole_layout(
    family: str, values: Values, draw: Callable[[Values, np.random.Generator], L],
) -> tuple[L, trimesh.Trimesh]:
    """The first layout `draw` makes from `layout_seed`'s generator that gives a whole part
    (`is_whole`), and its mesh; a draw that raises `NoRoom` is drawn again too.

    Raises:
        RuntimeError: If `MAX_DRAWS` layouts in a row fail (a bug of a drawer), naming `family`.
    """
    rng = np.random.default_rng(int(values["layout_seed"]))
    for _ in range(MAX_DRAWS):
        try:
            layout = draw(values, rng)
        except NoRoom:
            continue
        mesh = layout.mesh()
        if is_whole(mesh):
            return layout, mesh
    raise RuntimeError(f"{family}: no whole part in {MAX_DRAWS} draws of {dict(values)}")


def accepted_layout(values: Values) -> tuple[Layout, trimesh.Trimesh]:
    """The first layout drawn from `layout_seed` that makes a whole part, and its mesh.

    Raises:
        RuntimeError: If `MAX_DRAWS` layouts in a row fail (a bug of a feature drawer).
    """
    return first_whole_layout("procedural", values, draw_layout)


@register_family
class Procedural(PartFamily):
    name = "procedural"
    description = ("random constructive solid: plate, block or disc with pads, bosses, ribs, "
                   "holes, pockets, slots, steps, overhangs, undercuts")
    parameters = (
        Parameter("base_kind", 0, 2, "0 plate, 1 block, 2 disc", integer=True),
        Parameter("size_m", 0.07, 0.13, "bounding-sphere radius of the base body"),
        Parameter("width_ratio", 0.4, 1.0, "base width / length (plate, block)"),
        Parameter("height_ratio", 0.0, 1.0, "base height within its kind's range"),
        Parameter("feature_count", 2, 8, "features drawn on the base", integer=True),
        Parameter("layout_seed", 0, 2**31 - 1, "seeds the drawn features", integer=True),
    )

    def build(self, values: Values) -> trimesh.Trimesh:
        return accepted_layout(values)[1]
