"""The plan in a browser: one self-contained page (viser) that can be turned, zoomed and scrubbed.

The page holds the cell as MuJoCo compiled it (robot, sensor housing, fixture, static objects,
the part where the episode placed it), the views as numbered frusta in execution order, the
measured points coloured by view, the ground-truth points no view covered, and, under a
structured-light sensor, the points each frame lost by cause (`vprobot.render.lost`). With the
robot in the loop the page is a recording of the robot's timed cycle (`EpisodeRecord.timed`, on
the clock of the video: `vprobot.render.timeline`): its playback bar plays it and its slider
scrubs it.
A free-flying plan shows the sensor poses only. The cycle time and its parts are written over the
scene. viser's client is bundled in its wheel, and the scene is embedded in the page: opening it
fetches nothing.
"""

from __future__ import annotations

import contextlib
import dataclasses
import html
import io
import socket
from collections.abc import Iterator
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path

import mujoco
import numpy as np
import trimesh
import viser

from vprobot.cell.scene import STATIC_PREFIX
from vprobot.cell.sensor import LOSS_CAUSES
from vprobot.config.sensor import SensorModel
from vprobot.episode import EpisodeRecord, PartScene, describe_cycle
from vprobot.files.atomic import write_text
from vprobot.geometry.poses import quat_to_matrix
from vprobot.render.camera import overview_eye
from vprobot.render.lost import frame_losses, lost_in_order
from vprobot.render.markers import (
    LOST_RGBA,
    UNCOVERED_RGBA,
    UNREACHABLE_RGBA,
    rgb8,
    subsample,
    view_rgba,
)
from vprobot.render.picture import STATIC_ALPHA
from vprobot.render.timeline import TimingSettings, episode_timeline
from vprobot.robots.description import GEOM_GROUP_ROBOT

PAGE_FPS = 10.0
"""Robot poses per second of the cycle in the page's recording (its slider's resolution): each
pose is a message per moving body, which the page's writer and its browser both pay for."""
FRUSTUM_DEPTH_M = 0.08
"""Depth of the drawn frusta: enough to show the direction without hiding the part."""
POINTS_PER_VIEW = 3000
"""Measured points drawn per view (a random subset)."""
LOST_POINTS_PER_VIEW = 800
"""Lost points drawn per view and cause (a random subset): under structured light a frame loses
tens of thousands, which would bury the part."""
POINT_SIZE_M = 0.003
FLOOR_HALF_SIZE_M = 1.5
"""Half side of the drawn floor, which MuJoCo models as an infinite plane."""
ROBOT_PREFIX = "/robot"
"""Scene names of the robot's bodies (`/robot/<body>`): the nodes the slider moves."""
VIEWS_PREFIX = "/views"
"""Scene names of the view frusta (`/views/<number>`, 1-based in execution order)."""
_VISIBLE_GROUPS = (0, 1, GEOM_GROUP_ROBOT)
"""The geom groups MuJoCo's own viewer shows by default."""


@dataclasses.dataclass(frozen=True)
class Page:
    """A written page.

    Attributes:
        html: The page, self-contained.
        duration_s: Length of its recording (the cycle time; 0 without a timed robot).
        views: Frusta drawn (one per view of the plan).
    """

    html: str
    duration_s: float
    views: int


def geom_surface(model: mujoco.MjModel, geom: int) -> trimesh.Trimesh | None:
    """The surface of `geom` in its body's frame; None for a geom type without one drawn."""
    kind, size = model.geom_type[geom], model.geom_size[geom]
    shapes = mujoco.mjtGeom
    if kind == shapes.mjGEOM_MESH:
        mesh_id = model.geom_dataid[geom]
        start, count = model.mesh_vertadr[mesh_id], model.mesh_vertnum[mesh_id]
        first, faces = model.mesh_faceadr[mesh_id], model.mesh_facenum[mesh_id]
        mesh = trimesh.Trimesh(model.mesh_vert[start:start + count],
                               model.mesh_face[first:first + faces], process=False)
    elif kind == shapes.mjGEOM_BOX:
        mesh = trimesh.creation.box(extents=2.0 * size)
    elif kind == shapes.mjGEOM_SPHERE:
        mesh = trimesh.creation.icosphere(subdivisions=3, radius=size[0])
    elif kind == shapes.mjGEOM_ELLIPSOID:
        mesh = trimesh.creation.icosphere(subdivisions=3, radius=1.0)
        mesh.apply_scale(size)
    elif kind == shapes.mjGEOM_CYLINDER:
        mesh = trimesh.creation.cylinder(radius=size[0], height=2.0 * size[1], sections=32)
    elif kind == shapes.mjGEOM_CAPSULE:
        mesh = trimesh.creation.capsule(radius=size[0], height=2.0 * size[1])
    elif kind == shapes.mjGEOM_PLANE:
        # MuJoCo's plane is infinite where its size is zero.
        half = [s if s > 0 else FLOOR_HALF_SIZE_M for s in size[:2]]
        mesh = trimesh.creation.box(extents=[2.0 * half[0], 2.0 * half[1], 1e-3])
        mesh.apply_translation([0.0, 0.0, -5e-4])
    else:
        return None
    transform = np.eye(4)
    transform[:3, :3] = quat_to_matrix(model.geom_quat[geom])
    transform[:3, 3] = model.geom_pos[geom]
    return mesh.apply_transform(transform)


def _geom_rgba(model: mujoco.MjModel, geom: int) -> np.ndarray:
    material = model.geom_matid[geom]
    return model.mat_rgba[material] if material >= 0 else model.geom_rgba[geom]


def _moving_bodies(model: mujoco.MjModel) -> set[int]:
    """The bodies a joint moves: welded to a body other than the world (MuJoCo's
    `body_weldid`), and not mocap bodies (the part and the fixture), which are welded to
    themselves."""
    return {body for body in range(1, model.nbody)
            if model.body_weldid[body] != 0 and model.body_mocapid[body] < 0}


def _body_name(model: mujoco.MjModel, body: int) -> str:
    return model.body(body).name or f"body{body}"


class _PlanScene:
    """The scene of one episode on a viser server: the cell's bodies, the views, the points."""

    def __init__(self, server: viser.ViserServer, scene: PartScene, record: EpisodeRecord):
        self.server = server
        self.cell = scene.cell
        self.record = record
        self.robot = record.carrier == "robot"
        self.data = self.cell.make_data()
        self.cell.place_object(self.data, record.object_pose.rotation)
        self.data.qpos[:] = record.start_joints
        mujoco.mj_kinematics(self.cell.model, self.data)
        self.moving = _moving_bodies(self.cell.model)
        self.frames: dict[int, viser.FrameHandle] = {}
        self.lost_points = False
        self._add_bodies()
        self._add_views(SensorModel.from_config(self.cell.config.sensor))
        self._add_points(scene)

    def _add_bodies(self) -> None:
        model = self.cell.model
        robot_geoms = set(self.cell.robot_geom_ids.tolist())
        for body in range(model.nbody):
            geoms = [g for g in range(model.ngeom) if model.geom_bodyid[g] == body
                     and model.geom_group[g] in _VISIBLE_GROUPS
                     and _geom_rgba(model, g)[3] > 0.0
                     # A free-flying plan has no robot to show.
                     and (self.robot or g not in robot_geoms)]
            if not geoms:
                continue
            prefix = ROBOT_PREFIX if body in self.moving else "/cell"
            name = f"{prefix}/{_body_name(model, body)}"
            self.frames[body] = self.server.scene.add_frame(name, show_axes=False)
            for geom in geoms:
                mesh = geom_surface(model, geom)
                if mesh is None:
                    continue
                rgba = _geom_rgba(model, geom).copy()
                geom_name = model.geom(geom).name
                if geom_name.startswith(STATIC_PREFIX):
                    # See-through, as in the cell's picture: a guard wall or a column would
                    # hide the part from the page's camera.
                    rgba[3] = min(rgba[3], STATIC_ALPHA)
                self.server.scene.add_mesh_simple(
                    f"{name}/{geom_name or f'geom{geom}'}",
                    np.asarray(mesh.vertices, dtype=np.float32),
                    np.asarray(mesh.faces, dtype=np.uint32), color=rgb8(rgba),
                    opacity=float(rgba[3]) if rgba[3] < 1.0 else None)
        self.pose_bodies()

    def pose_bodies(self, moving_only: bool = False) -> None:
        """Place every drawn body (or only those a joint moves) where `self.data` has it."""
        for body, frame in self.frames.items():
            if not moving_only or body in self.moving:
                frame.position = self.data.xpos[body].copy()
                frame.wxyz = self.data.xquat[body].copy()

    def _add_views(self, sensor: SensorModel) -> None:
        width, height = sensor.resolution
        for index, view in enumerate(self.record.views):
            pose = view.sensor_pose if view.sensor_pose is not None else view.requested
            rgba = view_rgba(index) if view.reachable else UNREACHABLE_RGBA
            name = f"{VIEWS_PREFIX}/{index + 1}"
            self.server.scene.add_camera_frustum(
                name, fov=float(np.deg2rad(sensor.fov_deg[1])), aspect=width / height,
                scale=FRUSTUM_DEPTH_M, thickness=2.0, thickness_units="screen",
                color=rgb8(rgba),
                wxyz=pose.quaternion, position=pose.position)
            mark = "" if view.reachable else " (unreachable)"
            self.server.scene.add_label(f"{name}/number", f"{index + 1}{mark}",
                                        position=(0.0, 0.0, 0.0))

    def _add_points(self, scene: PartScene) -> None:
        for index, view in enumerate(self.record.views):
            points = subsample(view.points_world, POINTS_PER_VIEW, seed=index)
            if len(points):
                self._cloud(f"/points/view {index + 1}", points, view_rgba(index))
        missed = self.record.gt_points_world[~self.record.covered.astype(bool)]
        if len(missed):
            self._cloud("/points/missed", missed, UNCOVERED_RGBA)
        lost: dict[str, list[np.ndarray]] = {cause: [] for cause in LOSS_CAUSES}
        for index, losses in enumerate(frame_losses(scene, self.record)):
            if losses is not None:
                for cause, points in lost_in_order(losses):
                    lost[cause].append(subsample(points, LOST_POINTS_PER_VIEW, seed=index))
        for cause, parts in lost.items():
            points = np.concatenate(parts) if parts else np.zeros((0, 3))
            if len(points):
                self._cloud(f"/points/lost {cause}", points, LOST_RGBA[cause])
                self.lost_points = True

    def _cloud(self, name: str, points: np.ndarray, rgba: np.ndarray) -> None:
        self.server.scene.add_point_cloud(name, points.astype(np.float32), colors=rgb8(rgba),
                                          point_size=POINT_SIZE_M)


def _free_port(host: str) -> int:
    with socket.socket() as probe:
        probe.bind((host, 0))
        return int(probe.getsockname()[1])


@contextlib.contextmanager
def _quiet_server() -> Iterator[viser.ViserServer]:
    """A viser server on a free loopback port, for building a scene; stopped on exit."""
    # viser prints a banner at every start and stop, whatever `verbose` says, from its thread.
    with contextlib.redirect_stdout(io.StringIO()):
        server = viser.ViserServer(host="127.0.0.1", port=_free_port("127.0.0.1"),
                                   verbose=False)
        try:
            yield server
        finally:
            server.stop()


def _swatch(rgba: np.ndarray, text: str) -> str:
    red, green, blue = rgb8(rgba)
    return (f'<span style="color:rgb({red},{green},{blue})">&#9632;</span> '
            f"{html.escape(text)}")


def _caption(record: EpisodeRecord, title: str, cycle: str | None, lost_points: bool) -> str:
    """The text written over the scene: what the plan is, its coverage, its `cycle` time
    (`describe_cycle`), and what the colours mean."""
    reached = sum(view.reachable for view in record.views)
    lines = [html.escape(line) for line in (
        title, f"coverage {100.0 * record.coverage:.1f} %, {reached} of {len(record.views)} "
        f"views reached", cycle or "free-flying sensor: the sensor poses only")]
    lines.append("views: numbered frusta, their points in the same colour; "
                 + _swatch(UNREACHABLE_RGBA, "unreachable"))
    lines.append(_swatch(UNCOVERED_RGBA, "ground-truth points no view covered"))
    if lost_points:
        lines.append("lost by the frames: " + ", ".join(
            _swatch(LOST_RGBA[cause], cause) for cause in LOSS_CAUSES))
    return "".join(f"<div>{line}</div>" for line in lines)


OVERLAY_STYLE = ("position:fixed;left:0.6em;bottom:3.4em;z-index:10;max-width:40em;"
                 "padding:0.4em 0.6em;background:rgba(255,255,255,0.85);border-radius:4px;"
                 "font:12px/1.4 system-ui,sans-serif;pointer-events:none")


def plan_page(scene: PartScene, record: EpisodeRecord, title: str) -> Page:
    """The page of an episode (`episode_from_plan`, or a planner's run), self-contained.

    Args:
        scene: The part's scene the episode ran in.
        record: The episode.
        title: The first line written over the scene (what the plan is).

    Raises:
        ValueError: For an episode without views.
    """
    if not record.views:
        raise ValueError("the plan has no views to show")
    with _quiet_server() as server:
        server.scene.set_up_direction("+z")
        # An environment map and shadows cost a browser without a GPU seconds a frame; plain
        # lights show the cell as well.
        server.scene.configure_environment_map(None)
        server.scene.configure_default_lights(enabled=True, cast_shadow=False)
        server.scene.add_light_hemisphere("/lights/sky", intensity=1.5)
        eye, target = overview_eye(scene.cell)
        server.initial_camera.fov = float(np.deg2rad(scene.cell.model.vis.global_.fovy))
        server.initial_camera.position = eye
        server.initial_camera.look_at = target
        built = _PlanScene(server, scene, record)
        serializer = server.get_scene_serializer()
        timed = record.timed if built.robot else None
        cycle = describe_cycle(record)
        duration = 0.0
        if timed is not None:
            # The video's timeline on the cell's clock: the hold of a view is its acquisition.
            settings = TimingSettings(fps=PAGE_FPS, max_seconds_per_move=float("inf"),
                                      hold_seconds=scene.cell.config.sensor.acquisition_time_s,
                                      start_seconds=0.0, end_seconds=0.0)
            for state in episode_timeline(record, settings, timed):
                built.data.qpos[:] = state.joints
                mujoco.mj_kinematics(scene.cell.model, built.data)
                built.pose_bodies(moving_only=True)
                serializer.insert_sleep(state.repeat / PAGE_FPS)
                duration += state.repeat / PAGE_FPS
        page = serializer.as_html()
    overlay = (f'<div id="vprobot-caption" style="{OVERLAY_STYLE}">'
               f"{_caption(record, title, cycle, built.lost_points)}</div>")
    end = page.rindex("</body>")
    return Page(page[:end] + overlay + page[end:], duration, len(record.views))


def write_page(page: Page, path: str | Path) -> Path:
    """Write `page` to `path` atomically."""
    return write_text(Path(path), page.html)


def page_server(page: Page, host: str = "127.0.0.1", port: int = 0) -> ThreadingHTTPServer:
    """An HTTP server of `page` at `/` on `host`:`port` (0: a free port), bound but not yet
    serving (`serve_forever`); its address is `server_address`.

    Raises:
        ValueError: If the port is in use or the host cannot be bound.
    """
    body = page.html.encode()

    class Handler(BaseHTTPRequestHandler):
        def do_GET(self) -> None:
            if self.path.split("?")[0] not in ("/", "/index.html"):
                self.send_error(404, "the plan's page is at /")
                return
            self.send_response(200)
            self.send_header("Content-Type", "text/html; charset=utf-8")
            self.send_header("Content-Length", str(len(body)))
            self.end_headers()
            self.wfile.write(body)

        def log_message(self, format: str, *args: object) -> None:
            # One line per request would bury the address the user is told to open.
            return

    try:
        return ThreadingHTTPServer((host, port), Handler)
    except OSError as error:
        raise ValueError(f"cannot serve on {host}:{port} ({error.strerror or error}); give "
                         f"another --port (0: any free one) or --host") from None
