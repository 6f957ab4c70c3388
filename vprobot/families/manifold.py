"""Manifolds: bored bodies for training the hard cases (issue 46).

An instance is a hydraulic-manifold-like body, a block or a cylindrical housing, with a main
bore running through it along x, internal grooves cut inside that bore (rings of larger radius,
seen only by looking down the bore at an angle), cross bores that meet the main bore from a side
face (through the body or blind in its far wall) and blind ports on its faces, some
counterbored. The held-out valve bodies and pipe fittings are hard because their bores must be
seen and lit at once; this family puts such bores in training without copying a test object
(tests/test_manifold.py checks that no instance is a near-duplicate of one).

As in `procedural`, the top-level knobs are parameters and the layout of the features is drawn
inside `build` from a generator seeded by the `layout_seed` parameter, so (family, seed) fixes
the part and its JSON rebuilds it. A layout whose features find no room, or whose mesh is not one
closed solid within procedural's `RADIUS_RANGE_M`, is drawn again from the same generator, so
that redraws are reproducible too. Every feature keeps `WALL_M` of material to the faces and to
the others, so the booleans never meet on thin slivers.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from typing import Generic, TypeVar

import numpy as np
import trimesh

from vprobot.families.base import Parameter, PartFamily, Values, register_family
from vprobot.families.procedural import NoRoom, first_whole_layout
from vprobot.families.solids import OVERLAP_M, box, carve, cylinder_x, rod

BODY_KINDS = ("block", "cylinder")
WALL_M = 0.003
"""Least material between a feature and a face or another feature."""
_PLACE_TRIES = 30
"""Positions tried for a port on an end face before it goes on a side face."""
_BORE_SECTIONS = 64
"""Facets of the body's round side, the main bore and the grooves."""
_SECTIONS = 40
"""Facets of the cross bores and ports."""


@dataclasses.dataclass(frozen=True)
class Body:
    """The body, centred at the origin, its main bore along x.

    Attributes:
        kind: One of `BODY_KINDS`.
        length: Along x.
        width: Along y (a cylinder: its diameter).
        height: Along z (a cylinder: its diameter).
        bore_radius: Radius of the main bore.
    """

    kind: str
    length: float
    width: float
    height: float
    bore_radius: float

    @property
    def half_min(self) -> float:
        """Half the smaller cross-section size: the wall around the axis is this thick."""
        return min(self.width, self.height) / 2

    def half_along(self, direction: np.ndarray) -> float:
        """How far the side face lies from the axis along a unit `direction` of the y-z plane
        (one of +-y, +-z for a block)."""
        if self.kind == "cylinder":
            return self.width / 2
        return self.width / 2 if abs(direction[1]) > 0.5 else self.height / 2

    def solid(self) -> trimesh.Trimesh:
        """The body before any cut."""
        if self.kind == "cylinder":
            half = self.length / 2
            return cylinder_x(self.width / 2, -half, half, _BORE_SECTIONS)
        return box((self.length, self.width, self.height))

    def bore(self) -> trimesh.Trimesh:
        """The cut of the main bore, past both end faces."""
        half = self.length / 2 + OVERLAP_M
        return cylinder_x(self.bore_radius, -half, half, _BORE_SECTIONS)


@dataclasses.dataclass(frozen=True)
class Groove:
    """An internal groove: a ring of `radius` cut inside the main bore, `width` long along x
    and centred at `x`."""

    x: float
    width: float
    radius: float

    def cut(self) -> trimesh.Trimesh:
        return cylinder_x(self.radius, self.x - self.width / 2, self.x + self.width / 2,
                          _BORE_SECTIONS)


@dataclasses.dataclass(frozen=True)
class Bore:
    """A straight round bore into a face: a cross bore or a port.

    Attributes:
        kind: "cross_bore" (meets the main bore) or "port" (a blind bore beside it).
        mouth: Where its axis crosses the face it enters (a cylinder's side: the tangent point).
        bottom: Where it ends; for a through bore, where its axis leaves the far face.
        radius: Radius of the bore.
        through: Whether it runs out of the far face.
        counterbore_radius: Radius of the wider, shallow bore at the mouth; 0 for none.
        counterbore_depth: Depth of that counterbore from the mouth along the axis.
    """

    kind: str
    mouth: np.ndarray
    bottom: np.ndarray
    radius: float
    through: bool = False
    counterbore_radius: float = 0.0
    counterbore_depth: float = 0.0

    @property
    def axis(self) -> np.ndarray:
        """Unit vector from the mouth into the part."""
        span = self.bottom - self.mouth
        return span / np.linalg.norm(span)

    @property
    def on_end_face(self) -> bool:
        """Whether it enters an end face (parallel to the main bore), not a side face."""
        return abs(self.axis[0]) > 0.5

    def cuts(self) -> list[trimesh.Trimesh]:
        # The cut starts outside the face (and runs out of the far face when through) so that
        # no cut face lies on a face of the body.
        start = self.mouth - OVERLAP_M * self.axis
        end = self.bottom + OVERLAP_M * self.axis if self.through else self.bottom
        cuts = [rod(self.radius, start, end, _SECTIONS)]
        if self.counterbore_radius:
            cuts.append(rod(self.counterbore_radius, start,
                            self.mouth + self.counterbore_depth * self.axis, _SECTIONS))
        return cuts


@dataclasses.dataclass(frozen=True)
class Layout:
    """A drawn part: its body and features, and the mesh they make."""

    body: Body
    grooves: tuple[Groove, ...]
    cross_bores: tuple[Bore, ...]
    ports: tuple[Bore, ...]

    def mesh(self) -> trimesh.Trimesh:
        cuts = [self.body.bore(), *(g.cut() for g in self.grooves)]
        cuts += [c for b in (*self.cross_bores, *self.ports) for c in b.cuts()]
        return carve([self.body.solid()], cuts)


def body_of(values: Values) -> Body:
    """The body that the top-level parameters set; its bounding-sphere radius is `size_m`."""
    kind = BODY_KINDS[int(values["body_kind"])]
    size, length_ratio = values["size_m"], values["length_ratio"]
    if kind == "cylinder":
        radius = size / np.sqrt(length_ratio**2 + 1)
        width = height = 2 * radius
    else:
        height_ratio = values["section_ratio"]
        width = 2 * size / np.sqrt(length_ratio**2 + 1 + height_ratio**2)
        height = height_ratio * width
    bore = values["bore_ratio"] * min(width, height) / 2
    return Body(kind, float(length_ratio * width), float(width), float(height), float(bore))


F = TypeVar("F", Groove, Bore)


@dataclasses.dataclass(frozen=True)
class _Pending(Generic[F]):
    """A feature beside the main bore, drawn but not yet placed along x.

    Attributes:
        extent: How far it reaches along x either side of its centre.
        make: The feature centred at a given x.
    """

    extent: float
    make: Callable[[float], F]


def _side(rng: np.random.Generator, body: Body) -> tuple[np.ndarray, np.ndarray]:
    """A side face's outward normal and its in-face axis across x, both in the y-z plane: any
    direction on a cylinder, one of the four faces of a block."""
    if body.kind == "cylinder":
        angle = float(rng.uniform(0, 2 * np.pi))
    else:
        angle = int(rng.integers(4)) * np.pi / 2
    # Rounded so that a block's faces are exactly axis-aligned.
    normal = np.array([0.0, np.cos(angle), np.sin(angle)]).round(12)
    return normal, np.array([0.0, -normal[2], normal[1]])


def _groove(rng: np.random.Generator, body: Body, share: float) -> _Pending[Groove]:
    # Wider than the bore by 20-60 %, and two walls short of the outer faces.
    bore = body.bore_radius
    radius = float(min(bore * rng.uniform(1.2, 1.6), body.half_min - 2 * WALL_M))
    if radius < bore + 0.0015:
        raise NoRoom
    width = float(min(np.clip(rng.uniform(0.04, 0.1) * body.length, 0.004, 0.015), share))
    return _Pending(width / 2, lambda x: Groove(x, width, radius))


def _cross_bore(rng: np.random.Generator, body: Body, share: float) -> _Pending[Bore]:
    bore = body.bore_radius
    # Narrower than the main bore: equal radii would meet in a degenerate saddle.
    radius = float(min(bore * rng.uniform(0.4, 0.8), 0.012, share / 2))
    normal, _ = _side(rng, body)
    half = body.half_along(normal)
    if rng.random() < 0.5:
        return _Pending(radius, lambda x: Bore(
            "cross_bore", np.array([x, 0, 0]) + half * normal,
            np.array([x, 0, 0]) - half * normal, radius, through=True))
    # Blind: across the main bore, ending in the far wall with `WALL_M` left behind it (the
    # corners of its flat end come nearest a cylinder's curved side).
    far = bore + float(rng.uniform(0.3, 0.7)) * (half - bore - WALL_M)
    if body.kind == "cylinder":
        far = min(far, float(np.sqrt(max((half - WALL_M) ** 2 - radius**2, 0.0))))
    if far <= bore:
        raise NoRoom
    return _Pending(radius, lambda x: Bore(
        "cross_bore", np.array([x, 0, 0]) + half * normal, np.array([x, 0, 0]) - far * normal,
        radius))


def _sag(body: Body, offset: float) -> float:
    """How far a cylinder's side lies below its tangent plane `offset` off the tangent line."""
    if body.kind != "cylinder":
        return 0.0
    radius = body.width / 2
    return radius - float(np.sqrt(radius**2 - offset**2))


def _port(rng: np.random.Generator, body: Body, share: float, ends: dict[int, float],
          ) -> _Pending[Bore] | Bore:
    """A blind bore that stays `WALL_M` clear of the main bore and the faces it does not
    enter: into a free end face a third of the time (taking it in `ends`, by side, with its
    depth), else into a side face."""
    radius = float(min(np.clip(rng.uniform(0.08, 0.18) * body.half_min, 0.0025, 0.01),
                       share / 2))
    counterbore = float(min(radius * rng.uniform(1.4, 1.8), share / 2))
    if rng.random() < 0.5 or counterbore < 1.3 * radius:  # half are counterbored, if room
        counterbore = 0.0
    mouth_radius = max(radius, counterbore)
    if rng.random() < 1 / 3 and len(ends) < 2:
        end = _end_port(rng, body, share, ends, radius, counterbore)
        if end is not None:
            return end
    normal, across = _side(rng, body)
    half, bore = body.half_along(normal), body.bore_radius
    # A block's port may sit off the centre line of its face; clear of the main bore it may run
    # deeper than the bore's wall.
    lateral = 0.0 if body.kind == "cylinder" else body.half_along(across) - mouth_radius - WALL_M
    if lateral < 0:
        raise NoRoom
    offset = float(rng.uniform(-lateral, lateral))
    if abs(offset) < bore + mouth_radius + WALL_M:
        deepest = half - bore - WALL_M
    else:
        deepest = 2 * half - WALL_M
    depth = float(rng.uniform(0.5, 1.0) * deepest)
    # On a cylinder the counterbore's floor lies below the side's sag, so it is whole.
    sag = _sag(body, mouth_radius)
    counterbore_depth = sag + float(rng.uniform(0.2, 0.4)) * (depth - sag) if counterbore else 0.0
    if depth - max(sag, counterbore_depth) < 0.002:
        raise NoRoom

    def make(x: float) -> Bore:
        mouth = np.array([x, 0.0, 0.0]) + offset * across + half * normal
        return Bore("port", mouth, mouth - depth * normal, radius, False, counterbore,
                    counterbore_depth)

    return _Pending(mouth_radius, make)


def _end_port(rng: np.random.Generator, body: Body, share: float, ends: dict[int, float],
              radius: float, counterbore: float) -> Bore | None:
    """A blind bore into a free end face beside the main bore, parallel to it; None if there
    is no room on the face."""
    mouth_radius = max(radius, counterbore)
    side = int(rng.choice([s for s in (-1, 1) if s not in ends]))
    depth = float(min(rng.uniform(0.08, 0.25) * body.length, share))
    counterbore_depth = float(rng.uniform(0.2, 0.4) * depth) if counterbore else 0.0
    position = _end_position(rng, body, body.bore_radius + mouth_radius + WALL_M, mouth_radius)
    if position is None:
        return None
    ends[side] = depth
    mouth = np.array([side * body.length / 2, *position])
    return Bore("port", mouth, mouth - side * depth * np.array([1.0, 0.0, 0.0]), radius, False,
                counterbore, counterbore_depth)


def _end_position(rng: np.random.Generator, body: Body, inner: float, mouth_radius: float,
                  ) -> tuple[float, float] | None:
    """Where on an end face a bore of `mouth_radius` keeps `inner` from the axis and `WALL_M`
    from the side faces; None if no draw of `_PLACE_TRIES` does."""
    if body.kind == "cylinder":
        outer = body.width / 2 - mouth_radius - WALL_M
        if outer < inner:
            return None
        distance, angle = rng.uniform(inner, outer), rng.uniform(0, 2 * np.pi)
        return float(distance * np.cos(angle)), float(distance * np.sin(angle))
    reach = (body.width / 2 - mouth_radius - WALL_M, body.height / 2 - mouth_radius - WALL_M)
    if min(reach) < 0:
        return None
    for _ in range(_PLACE_TRIES):
        y, z = (float(rng.uniform(-r, r)) for r in reach)
        if np.hypot(y, z) >= inner:
            return y, z
    return None


def _spread(rng: np.random.Generator, body: Body, extents: list[float],
            ends: dict[int, float]) -> list[float]:
    """Centres along x of features reaching `extents` either side: in a random order, between
    the end ports (`ends`), `WALL_M` apart and from the ends at least, the room left over
    shared out at random."""
    low, high = -body.length / 2 + ends.get(-1, 0.0), body.length / 2 - ends.get(1, 0.0)
    slack = high - low - 2 * sum(extents) - (len(extents) + 1) * WALL_M
    assert slack >= -1e-12, "the features' share of the length is too large"
    gaps = max(slack, 0.0) * rng.dirichlet(np.ones(len(extents) + 1))
    centres = [0.0] * len(extents)
    cursor = low + WALL_M + gaps[0]
    for gap, index in zip(gaps[1:], rng.permutation(len(extents)), strict=True):
        centres[index] = float(cursor + extents[index])
        cursor += 2 * extents[index] + WALL_M + gap
    return centres


def draw_layout(values: Values, rng: np.random.Generator) -> Layout:
    """The body and its grooves, cross bores and ports.

    Each feature is sized to its share of the body's length, so that all of them fit along it
    in a row, `WALL_M` apart, whatever their order: features at different x never meet.

    Raises:
        NoRoom: If a feature finds no room on this body (the caller draws again).
    """
    body = body_of(values)
    counts = [int(values[name]) for name in ("groove_count", "cross_bore_count", "port_count")]
    share = (body.length - WALL_M) / max(sum(counts), 1) - WALL_M
    grooves = [_groove(rng, body, share) for _ in range(counts[0])]
    cross = [_cross_bore(rng, body, share) for _ in range(counts[1])]
    ends: dict[int, float] = {}
    ports = [_port(rng, body, share, ends) for _ in range(counts[2])]
    side_ports = [p for p in ports if isinstance(p, _Pending)]
    extents = ([p.extent for p in grooves] + [p.extent for p in cross]
               + [p.extent for p in side_ports])
    centres = iter(_spread(rng, body, extents, ends))
    placed_grooves = tuple(p.make(next(centres)) for p in grooves)
    placed_cross = tuple(p.make(next(centres)) for p in cross)
    placed_ports = tuple(p.make(next(centres)) if isinstance(p, _Pending) else p for p in ports)
    return Layout(body, placed_grooves, placed_cross, placed_ports)


def accepted_layout(values: Values) -> tuple[Layout, trimesh.Trimesh]:
    """The first layout drawn from `layout_seed` that makes a whole part, and its mesh.

    Raises:
        RuntimeError: If `procedural.MAX_DRAWS` layouts in a row fail (a bug of the drawer).
    """
    return first_whole_layout("manifold", values, draw_layout)


@register_family
class Manifold(PartFamily):
    name = "manifold"
    description = ("bored block or cylindrical housing: main through bore, internal grooves, "
                   "cross bores, counterbored ports")
    parameters = (
        Parameter("body_kind", 0, 1, "0 block, 1 cylindrical housing", integer=True),
        Parameter("size_m", 0.08, 0.135, "bounding-sphere radius of the body"),
        Parameter("length_ratio", 1.2, 2.2, "length / width (cylinder: diameter)"),
        Parameter("section_ratio", 0.7, 1.0, "height / width (block)"),
        Parameter("bore_ratio", 0.3, 0.5, "main bore radius / half the smaller section size"),
        Parameter("groove_count", 0, 2, "internal grooves in the main bore", integer=True),
        Parameter("cross_bore_count", 0, 3, "bores from a side face into the main bore",
                  integer=True),
        Parameter("port_count", 0, 3, "blind bores on faces, half counterbored", integer=True),
        Parameter("layout_seed", 0, 2**31 - 1, "seeds the drawn features", integer=True),
    )

    def build(self, values: Values) -> trimesh.Trimesh:
        return accepted_layout(values)[1]
