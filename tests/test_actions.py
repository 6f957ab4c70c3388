"""Action mappings against hand-computed poses (docs/states-actions-rewards.md#actions)."""

from __future__ import annotations

import dataclasses

import gymnasium as gym
import numpy as np
import pytest

from vprobot.config import Config, EnvConfig
from vprobot.coverage.occupancy import VOXEL_M
from vprobot.env.actions import ACTION_SIZES, ActionMapping
from vprobot.episode.views import band_candidates

R = 0.47


def mapping(action: str, **changes: object) -> ActionMapping:
    return ActionMapping(dataclasses.replace(EnvConfig(), action=action, **changes), R)


def test_a2s0r_zero_looks_at_centre_from_phi_pi_theta_half_pi() -> None:
    view = mapping("A_2S0R").view(np.zeros(2))
    # phi = pi, theta = pi / 2 at 0.47 m: on the -x axis, level with the centre.
    np.testing.assert_allclose(view.pose.position, [-R, 0.0, 0.0], atol=1e-12)
    np.testing.assert_allclose(view.pose.view_axis, [1.0, 0.0, 0.0], atol=1e-12)
    np.testing.assert_array_equal(view.look_at_point, [0.0, 0.0, 0.0])
    assert view.roll_free


def test_a2s0r_extremes() -> None:
    top = mapping("A_2S0R").view(np.array([-1.0, -1.0]))  # theta = 0: straight above
    np.testing.assert_allclose(top.pose.position, [0.0, 0.0, R], atol=1e-12)
    np.testing.assert_allclose(top.pose.view_axis, [0.0, 0.0, -1.0], atol=1e-12)
    side = mapping("A_2S0R").view(np.array([-0.5, 0.0]))  # phi = pi / 2
    np.testing.assert_allclose(side.pose.position, [0.0, R, 0.0], atol=1e-12)


def test_a3s0r_radius_npk_and_wpk() -> None:
    near = mapping("A_3S0R").view(np.array([0.0, 0.0, -0.5]))  # r = 0.25 of [0, 1]
    np.testing.assert_allclose(near.pose.position, [-0.25, 0.0, 0.0], atol=1e-12)
    fixed = mapping("A_3S0R", position_mapping="wpk").view(np.array([0.0, 0.0, -0.5]))
    np.testing.assert_allclose(fixed.pose.position, [-R, 0.0, 0.0], atol=1e-12)


def test_absolute_euler_angles() -> None:
    # alpha = pi / 2, beta = pi / 2: the viewing axis is (0, 1, 0), wherever the sensor is.
    view = mapping("A_2S2R").view(np.array([0.0, 0.0, -0.5, 0.0]))
    np.testing.assert_allclose(view.pose.view_axis, [0.0, 1.0, 0.0], atol=1e-12)
    np.testing.assert_allclose(view.pose.position, [-R, 0.0, 0.0], atol=1e-12)
    assert view.look_at_point is None and not view.roll_free
    view = mapping("A_3S2R").view(np.array([0.0, 0.0, 1.0, -1.0, 1.0]))  # alpha 0, beta pi
    np.testing.assert_allclose(view.pose.view_axis, [0.0, 0.0, -1.0], atol=1e-12)
    np.testing.assert_allclose(view.pose.position, [-1.0, 0.0, 0.0], atol=1e-12)


def test_limited_deviation_from_look_at() -> None:
    centred = mapping("A_2S2R_lim").view(np.zeros(4))
    np.testing.assert_allclose(centred.pose.view_axis, [1.0, 0.0, 0.0], atol=1e-12)
    for action in ([0, 0, 1.0, 0], [0, 0, 0, -1.0]):
        turned = mapping("A_2S2R_lim").view(np.array(action, dtype=float))
        angle = np.degrees(np.arccos(turned.pose.view_axis @ [1.0, 0.0, 0.0]))
        assert angle == pytest.approx(10.0)
    both = mapping("A_3S2R_lim").view(np.array([0.0, 0.0, 0.0, 1.0, 1.0]))
    angle = np.degrees(np.arccos(both.pose.view_axis @ [1.0, 0.0, 0.0]))
    assert 10.0 < angle < 14.2


def test_cartesian_npk_and_wpk() -> None:
    view = mapping("A_3C0R").view(np.array([0.2, -0.3, 0.4]))
    np.testing.assert_allclose(view.pose.position, [0.2, -0.3, 0.4])
    np.testing.assert_allclose(view.pose.view_axis, -view.pose.position / np.linalg.norm(
        view.pose.position))
    close = mapping("A_3C0R", position_mapping="wpk").view(np.array([0.1, 0.0, 0.0]))
    np.testing.assert_allclose(close.pose.position, [0.20, 0.0, 0.0])
    far = mapping("A_3C0R", position_mapping="wpk").view(np.array([1.0, 1.0, 0.0]))
    assert np.linalg.norm(far.pose.position) == pytest.approx(0.50)
    aimed = mapping("A_3C2R").view(np.array([0.5, 0.0, 0.0, -0.5, 0.0]))
    np.testing.assert_allclose(aimed.pose.view_axis, [0.0, 1.0, 0.0], atol=1e-12)


@pytest.mark.parametrize("name", list(ACTION_SIZES))
def test_every_variant_gives_rotations(name: str) -> None:
    rng = np.random.default_rng(0)
    for _ in range(20):
        pose = mapping(name).view(rng.uniform(-1, 1, ACTION_SIZES[name])).pose
        np.testing.assert_allclose(pose.rotation.T @ pose.rotation, np.eye(3), atol=1e-12)
        assert np.linalg.det(pose.rotation) == pytest.approx(1.0)


@pytest.mark.parametrize(
    ("action", "message"),
    [
        ([np.nan, 0.0, 0.0, 0.0, 0.0], "finite"),
        ([0.0, 0.0, 0.0, 0.0], r"shape \(5,\)"),
        ([0.0, 0.0, 1.5, 0.0, 0.0], r"\[-1, 1\]"),
    ],
)
def test_bad_actions(action: list, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        mapping("A_3S2R_lim").view(np.array(action))


def test_a_view_action_k_requests_the_target_nbv_requests_as_candidate_k() -> None:
    config = Config()
    view = ActionMapping(dataclasses.replace(config.env, action="A_view"),
                         config.sensor.working_distance_m)
    band = band_candidates(config, VOXEL_M)
    assert view.space == gym.spaces.Discrete(len(band)) and len(band) == 128
    center = np.asarray(config.cell.object_center_m)
    for k in (0, 17, np.int64(127), np.array([64])):
        target = view.target(k, center, roll_free=True)
        expected = band.targets[int(np.asarray(k).reshape(-1)[0])]
        np.testing.assert_allclose(target.pose.position, expected.pose.position, atol=1e-12)
        np.testing.assert_allclose(target.pose.rotation, expected.pose.rotation, atol=1e-12)
        assert target.roll_free == expected.roll_free


@pytest.mark.parametrize("action", [128, -1, 1.0, [1, 2]])
def test_bad_a_view_actions_name_what_is_allowed(action: object) -> None:
    with pytest.raises(ValueError, match=r"A_view must be one integer in \[0, 128\)"):
        mapping("A_view").view(action)  # type: ignore[arg-type]
