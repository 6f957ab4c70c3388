"""Sensor presets and the sensor model, checked against their datasheet figures.

The references below are the datasheet numbers themselves (resolution, field of view as an
area at a distance or as focal lengths, range, working distance), not values read back from the
code: each preset must make the sensor measure what its datasheet predicts.
"""

from __future__ import annotations

import dataclasses
import json
import math
import re
from pathlib import Path

import numpy as np
import pytest
import trimesh
import yaml
from helpers import make_scene

import vprobot.coverage.ground_truth as gt_module
from vprobot.cell.sensor import DepthSensor
from vprobot.cli import main
from vprobot.config import (
    Config,
    ConfigError,
    SensorConfig,
    available_sensors,
    load_config,
    sensor_preset,
    with_sensor,
)
from vprobot.config.sensor import SensorModel
from vprobot.files.paths import SENSORS_DIR
from vprobot.files.schema import read_yaml
from vprobot.geometry.poses import Pose
from vprobot.plan import plan_config


@dataclasses.dataclass(frozen=True)
class Datasheet:
    """A device's figures: tangents of the half opening angles, range and working distance."""

    resolution: tuple[int, int]
    half_tangents: tuple[float, float]
    near_m: float
    far_m: float
    working_distance_m: float


DATASHEETS = {
    # Paper Table 4: 27 x 25 degrees.
    "paper": Datasheet((430, 300), (math.tan(math.radians(13.5)), math.tan(math.radians(12.5))),
                       0.30, 0.50, 0.47),
    # 570 x 460 mm at 600 mm.
    "zivid2plus_mr60": Datasheet((2448, 2048), (285 / 600, 230 / 600), 0.30, 1.10, 0.60),
    # Focal lengths 2268.68 / 2268.88 px over 2064 x 1544 pixels.
    "phoxi_m": Datasheet((2064, 1544), (1032 / 2268.68, 772 / 2268.88), 0.458, 1.118, 0.788),
    # Focal lengths 2245.92 / 2246.5 px over 2064 x 1544 pixels; sweet spot 442 mm.
    "phoxi_s": Datasheet((2064, 1544), (1032 / 2245.92, 772 / 2246.5), 0.384, 0.520, 0.442),
}
"""The bundled presets' datasheet figures, typed in from the datasheets (a new preset needs none
here, but names its source: `test_every_preset_names_its_source`)."""
REAL_DEVICES = ("zivid2plus_mr60", "phoxi_m", "phoxi_s")
BODIES_M = {
    # Datasheet 77 x 68 x 296 mm; the collision mesh of aist_phoxi_camera 76.6 x 295.6 x 67.9.
    "phoxi_s": (0.296, 0.068, 0.077),
    # That driver's PhoXi M mesh: 76.6 x 415.6 x 67.9 mm.
    "phoxi_m": (0.416, 0.068, 0.077),
    # zivid-ros's Zivid 2+ convex hull, boxed in the optical frame (turned 2.5 deg in the body).
    "zivid2plus_mr60": (0.169, 0.057, 0.123),
}
"""The real devices' bodies, full extents (m) along x (the baseline), y and z (the view)."""


def _pixel_centres(sheet: Datasheet) -> tuple[np.ndarray, np.ndarray]:
    """Tangents of the pixel centres of an even grid over the datasheet's field of view."""
    (width, height), (half_x, half_y) = sheet.resolution, sheet.half_tangents
    return (half_x * (2 * np.arange(width) + 1 - width) / width,
            half_y * (2 * np.arange(height) + 1 - height) / height)


def test_the_bundled_presets_are_there() -> None:
    assert set(DATASHEETS) <= set(available_sensors())


@pytest.mark.parametrize("name", available_sensors())
def test_every_preset_names_its_source(name: str) -> None:
    """In the comments above its first key: a `# Source:` line naming the datasheet."""
    lines = (SENSORS_DIR / f"{name}.yaml").read_text().splitlines()
    header = lines[:next(i for i, line in enumerate(lines) if not line.startswith("#"))]
    assert any(line.startswith("# Source: ") for line in header)


@pytest.mark.parametrize("name", sorted(DATASHEETS))
def test_preset_holds_its_datasheet_figures(name: str) -> None:
    sensor, sheet = sensor_preset(name), DATASHEETS[name]
    assert sensor.resolution == sheet.resolution
    assert (sensor.near_m, sensor.far_m) == (sheet.near_m, sheet.far_m)
    assert sensor.working_distance_m == sheet.working_distance_m
    # The presets round the derived angles to 0.01 degrees.
    half_tangents = [math.tan(math.radians(angle / 2)) for angle in sensor.fov_deg]
    np.testing.assert_allclose(half_tangents, sheet.half_tangents, rtol=3e-4)
    # The mount is the cell's: every preset keeps the default one.
    assert sensor.mount_position_m == SensorConfig().mount_position_m


@pytest.mark.parametrize("name", available_sensors())
def test_every_preset_gives_its_acquisition_time_and_says_where_it_comes_from(name: str) -> None:
    lines = (SENSORS_DIR / f"{name}.yaml").read_text().splitlines()
    at = next(i for i, line in enumerate(lines) if line.startswith("acquisition_time_s:"))
    assert lines[at - 1].startswith("#")
    assert any(label in "\n".join(lines[at - 4:at]) for label in ("ASSUMPTION", "ESTIMATE"))
    assert sensor_preset(name).acquisition_time_s > 0


@pytest.mark.parametrize("name", REAL_DEVICES)
def test_real_preset_has_its_bodys_housing_behind_the_range_around_the_camera(name: str) -> None:
    sensor = sensor_preset(name)
    housing = sensor.housing
    assert housing.shape == "box" and housing.size_m == BODIES_M[name]
    assert housing.rpy_deg == (0.0, 0.0, 0.0)
    half = np.array(housing.size_m) / 2
    low, high = np.array(housing.position_m) - half, np.array(housing.position_m) + half
    # The camera (the sensor frame's origin) lies in the body's outline across the view ...
    assert np.all(low[:2] < 0.0) and np.all(high[:2] > 0.0)
    # ... the projector, `baseline_m` along +x, too, where the baseline is sourced (the
    # Zivid's is an estimate, 8 mm longer than its body allows) ...
    assert sensor.structured_light is not None
    if name.startswith("phoxi"):
        assert low[0] < sensor.structured_light.baseline_m < high[0]
    # ... and no part of the body reaches into the range the sensor measures.
    assert high[2] < sensor.near_m


@pytest.mark.parametrize("name", available_sensors())
def test_every_preset_gives_its_payload_and_says_where_it_comes_from(name: str) -> None:
    lines = (SENSORS_DIR / f"{name}.yaml").read_text().splitlines()
    labels = ("ASSUMPTION", "ESTIMATE")
    if name == "paper":  # the schema's default housing and mass, said to be assumed
        assert any(label in line and "housing" in line for line in lines for label in labels)
        assert not any(line.startswith(("housing:", "mass_kg:")) for line in lines)
        return
    at = next(i for i, line in enumerate(lines) if line.startswith("mass_kg:"))
    assert any(label in "\n".join(lines[at - 3:at]) for label in labels)
    assert 0.1 < sensor_preset(name).mass_kg < 5.0


def test_paper_preset_is_the_default_sensor() -> None:
    assert sensor_preset("paper") == SensorConfig() == Config().sensor


@pytest.mark.parametrize("name", REAL_DEVICES)
def test_sphere_at_the_working_distance_shows_the_cap_the_datasheet_predicts(name: str) -> None:
    sheet = DATASHEETS[name]
    distance = sheet.working_distance_m
    # A sphere whose apex lies inside the range (the PhoXi S measures from 58 mm nearer only).
    radius = min(0.1, 0.9 * (distance - sheet.near_m))
    sphere = trimesh.creation.icosphere(subdivisions=6, radius=radius)
    # Largest angle between neighbouring vertices: how far a facet strays from the sphere.
    edge = sphere.vertices[sphere.edges_unique]
    facet_angle = float(np.arccos(np.einsum("ij,ij->i", edge[:, 0], edge[:, 1]).min()
                                  / radius**2))
    scene, data = make_scene(sphere)
    pose = Pose.look_at([0.0, 0.0, distance], [0.0, 0.0, 0.0])
    sensor = DepthSensor(scene, SensorModel.from_config(sensor_preset(name)), workers=1)
    points = sensor.acquire_from_pose(data, pose).points_world

    # (a) Every point lies on the visible cap, cos(polar) >= R / D, up to one facet.
    polar = np.arccos(np.clip(points[:, 2] / np.linalg.norm(points, axis=1), -1.0, 1.0))
    assert polar.max() <= math.acos(radius / distance) + facet_angle
    # ... and the cloud spans it: from the apex, D - R away, out to the limb circle of radius
    # R sqrt(1 - (R / D)^2), within a pixel there (and, by (a), a facet beyond it).
    nearest = np.linalg.norm(points - pose.position, axis=1).min()
    assert distance - radius <= nearest <= distance - radius * math.cos(facet_angle)
    limb_depth = math.sqrt(distance**2 - radius**2)
    pixel = 2 * max(sheet.half_tangents[0] / sheet.resolution[0],
                    sheet.half_tangents[1] / sheet.resolution[1]) * limb_depth
    lateral = np.hypot(points[:, 0], points[:, 1]).max()
    limb = radius * math.sqrt(1 - (radius / distance) ** 2)
    assert limb - pixel - radius * facet_angle**2 <= lateral
    assert lateral <= radius * math.sin(math.acos(radius / distance) + facet_angle)

    # (b) One point per pixel-centre ray within the cone of half-angle asin(R / D).
    u, v = _pixel_centres(sheet)
    cone_tangent = radius / limb_depth
    expected = int(np.count_nonzero(u[None, :] ** 2 + v[:, None] ** 2 < cone_tangent**2))
    assert expected > 100_000
    assert len(points) == pytest.approx(expected, rel=2e-3)


def _plate_cloud(name: str, distance: float) -> np.ndarray:
    """The cloud of a 0.15 m square plate facing the sensor, its front face `distance` away."""
    side, thickness = 0.15, 0.01
    scene, data = make_scene(trimesh.creation.box((side, side, thickness)))
    # Slightly off the grid's symmetry: no pixel centre lies on the plate's edge.
    pose = Pose.look_at([0.00013, -0.00021, thickness / 2 + distance],
                        [0.00013, -0.00021, 0.0])
    sensor = DepthSensor(scene, SensorModel.from_config(sensor_preset(name)), workers=1)
    return sensor.acquire_from_pose(data, pose).points_world


@pytest.mark.parametrize("name", sorted(DATASHEETS))
def test_point_density_at_the_working_distance_is_the_datasheets(name: str) -> None:
    sheet = DATASHEETS[name]
    distance = sheet.working_distance_m
    points = _plate_cloud(name, distance)
    np.testing.assert_allclose(points[:, 2], 0.005, atol=1e-6)
    # Pixels over the area the field of view covers at that distance (for the Zivid exactly
    # 2448 x 2048 over 570 x 460 mm).
    (width, height), (half_x, half_y) = sheet.resolution, sheet.half_tangents
    density = width * height / (2 * distance * half_x * 2 * distance * half_y)
    assert len(points) / 0.15**2 == pytest.approx(density, rel=0.01)


def test_two_presets_differ_as_their_datasheets_say() -> None:
    # At 0.6 m, beyond the paper sensor's far bound of 0.5 m but in the Zivid's range.
    assert len(_plate_cloud("paper", 0.6)) == 0
    # At 0.47 m both measure the plate; their densities differ by the datasheets' ratio of
    # pixels per unit of tan^2.
    zivid, paper = _plate_cloud("zivid2plus_mr60", 0.47), _plate_cloud("paper", 0.47)

    def per_tangent_area(sheet: Datasheet) -> float:
        return np.prod(sheet.resolution) / (4 * np.prod(sheet.half_tangents))

    ratio = per_tangent_area(DATASHEETS["zivid2plus_mr60"]) / per_tangent_area(DATASHEETS["paper"])
    assert ratio > 5
    assert len(zivid) / len(paper) == pytest.approx(ratio, rel=0.02)


def test_sensor_model_geometry_matches_the_pinhole_maths() -> None:
    model = SensorModel.from_config(sensor_preset("zivid2plus_mr60")).at_resolution((49, 41))
    half_x, half_y = (math.tan(math.radians(angle / 2)) for angle in (50.82, 41.95))
    pose = Pose.look_at([0.1, 0.2, 0.9], [0.3, -0.1, 0.2])
    corners = (model.frustum_corners(pose, 0.7) - pose.position) @ pose.rotation
    # Clockwise in the image from the top left (+x right, +y down).
    np.testing.assert_allclose(corners, [[-0.7 * half_x, -0.7 * half_y, 0.7],
                                         [0.7 * half_x, -0.7 * half_y, 0.7],
                                         [0.7 * half_x, 0.7 * half_y, 0.7],
                                         [-0.7 * half_x, 0.7 * half_y, 0.7]], atol=1e-12)
    directions = model.ray_directions
    np.testing.assert_allclose(np.linalg.norm(directions, axis=1), 1.0)
    grid = (directions[:, :2] / directions[:, 2:]).reshape(41, 49, 2)
    np.testing.assert_allclose(grid[0, :, 0], half_x * (2 * np.arange(49) - 48) / 49)
    np.testing.assert_allclose(grid[:, 0, 1], half_y * (2 * np.arange(41) - 40) / 41)
    # The enclosing cone holds the corner pixels' rays; the inscribed one touches the nearer
    # frame edge.
    assert model.cone_angle_rad == pytest.approx(
        math.atan(math.hypot(half_x * 48 / 49, half_y * 40 / 41)))
    assert math.tan(model.inscribed_cone_angle_rad) == pytest.approx(half_y)
    inside = np.array([[0.0, 0.0, 0.6], [0.79 * half_x, -0.79 * half_y, 0.8]])
    outside = np.array([[1.01 * half_x, 0.0, 1.0], [0.0, 0.0, 0.29], [0.0, 0.0, 1.11],
                        [0.0, 0.0, -0.6]])
    assert model.contains(inside).all() and not model.contains(outside).any()


@pytest.mark.parametrize(("changes", "message"), [
    ({"resolution": (0, 10)}, r"resolution must lie in 1\.\.4096 .* got \(0, 10\)"),
    ({"resolution": (5000, 10)}, r"in 1\.\.4096"),
    ({"fov_deg": (179.9, 20.0)}, r"fov_deg must be two opening angles in \(0, 120\]"),
    ({"near_m": 0.6, "far_m": 0.5}, r"0 <= near_m < far_m .* near_m=0\.6"),
    ({"working_distance_m": 0.0}, r"working_distance_m must lie in \(near_m, far_m\] = "
                                  r"\(0\.1, 1\], got 0"),
])
def test_bad_sensor_model_is_a_clear_error(changes: dict, message: str) -> None:
    values = {"resolution": (10, 10), "fov_deg": (20.0, 20.0), "near_m": 0.1, "far_m": 1.0,
              "working_distance_m": 0.5, **changes}
    with pytest.raises(ValueError, match=message):
        SensorModel(**values)


@pytest.mark.parametrize(("changes", "message"), [
    # Each used to be accepted, and the first frame took gigabytes (a million metres of baseline
    # widen the projector's shadow grid; a far range of kilometres, the rays' samples).
    ({"structured_light": {"baseline_m": 1e6}},
     r"^sensor\.structured_light\.baseline_m must be in \(0, 1\] m \(finite\), got 1000000\.0$"),
    # Within the 1 m, but 3.2 frame widths seen from the near range: the datasheet's frame is
    # 570 mm wide at 600 mm, so two frames at 0.30 m are 2 * 0.95 * 0.30 = 0.570 m.
    ({"structured_light": {"baseline_m": 0.9}},
     r"^sensor\.structured_light\.baseline_m must be at most 0\.570\d m for this sensor's near_m "
     r"and fov_deg, got 0\.9: seen from the near end of the range the projector may sit at most "
     r"2 frame widths \(2 near_m tan\(fov_x / 2\)\) from the camera$"),
    ({"far_m": 1e6, "working_distance_m": 1.0},
     r"^sensor needs 0 <= near_m < far_m <= 10 m, got near_m=0\.3, far_m=1000000\.0$"),
    ({"acquisition_time_s": 1e9},
     r"^sensor\.acquisition_time_s must lie in \[0, 60\] s, got 1000000000\.0$"),
])
def test_a_preset_value_beyond_its_physical_range_is_refused_naming_the_range(
        tmp_path: Path, changes: dict, message: str) -> None:
    figures = read_yaml(SENSORS_DIR / "zivid2plus_mr60.yaml")
    light = {**figures["structured_light"], **changes.get("structured_light", {})}
    preset = tmp_path / "preset.yaml"
    preset.write_text(yaml.safe_dump({**figures, **changes, "structured_light": light}))
    with pytest.raises(ConfigError, match=message):
        sensor_preset(str(preset))


def _write(path: Path, text: str) -> Path:
    path.write_text(text)
    return path


def test_config_names_a_preset_or_overrides_one(tmp_path: Path) -> None:
    by_name = load_config(_write(tmp_path / "a.yaml", "sensor: zivid2plus_mr60\n"))
    assert by_name.sensor == sensor_preset("zivid2plus_mr60")
    overridden = load_config(_write(tmp_path / "b.yaml", (
        "sensor:\n  preset: phoxi_m\n  mount_position_m: [0.0, 0.01, 0.12]\n"
        "  working_distance_m: 0.65\n")))
    assert overridden.sensor == dataclasses.replace(
        sensor_preset("phoxi_m"), mount_position_m=(0.0, 0.01, 0.12), working_distance_m=0.65)


@pytest.mark.parametrize("text", ["sensor: kinect\n", "sensor:\n  preset: kinect\n"])
def test_unknown_preset_lists_the_presets(tmp_path: Path, text: str) -> None:
    with pytest.raises(ConfigError, match=re.escape(
            f"one of {available_sensors()}, or a preset's YAML file, got 'kinect'")):
        load_config(_write(tmp_path / "c.yaml", text))


def test_sensor_option_swaps_the_device_and_keeps_the_mount() -> None:
    mounted = dataclasses.replace(Config(), sensor=dataclasses.replace(
        SensorConfig(), mount_position_m=(0.01, 0.0, 0.1)))
    swapped = with_sensor(mounted, "phoxi_m").sensor
    assert swapped == dataclasses.replace(sensor_preset("phoxi_m"),
                                          mount_position_m=(0.01, 0.0, 0.1))


def test_cli_sensor_option_changes_the_sensor_used(tmp_path: Path) -> None:
    out = tmp_path / "view.json"
    assert main(["reach", "--position", "0.45", "-0.6", "0.75", "--look-at", "0.45", "0", "0.75",
                 "--sensor", "zivid2plus_mr60", "--json", str(out)]) == 0
    document = json.loads(out.read_text())
    sensor = document["sensor"]
    assert (sensor["resolution"], sensor["range"]) == ([2448, 2048], [0.30, 1.10])
    # Replaying the plan under the default config restores the whole sensor it was made with.
    replayed = plan_config(Config(), document, np.array([0.45, 0.0, 0.75]), out).sensor
    assert replayed == sensor_preset("zivid2plus_mr60")
    assert main(["reach", "--position", "0", "0", "1", "--look-at", "1", "0", "0",
                 "--sensor", "kinect"]) == 2


def test_ground_truth_cache_key_includes_the_sensor() -> None:
    box = trimesh.creation.box((0.1, 0.1, 0.1))
    keys = {gt_module._cache_key(box, with_sensor(Config(), name)) for name in DATASHEETS}
    assert len(keys) == len(DATASHEETS)
    assert gt_module._cache_key(box, with_sensor(Config(), "paper")) == gt_module._cache_key(
        box, Config())


def test_sensors_command_lists_every_preset(capsys: pytest.CaptureFixture) -> None:
    assert main(["sensors"]) == 0
    rows = capsys.readouterr().out.splitlines()[1:]
    assert [row.split()[0] for row in rows] == sorted(DATASHEETS)
    assert "2448 x 2048   50.82 x 41.95   0.300 - 1.100  0.600" in rows[3]
