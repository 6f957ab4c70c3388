"""The inspection engine: part scenes, sensor carriers, episodes, their specs and records."""

from vprobot.episode.carrier import CARRIERS, Carrier, CarrierName
from vprobot.episode.cycle import describe_cycle, episode_moves, timed_cycle
from vprobot.episode.engine import Episode, make_carrier
from vprobot.episode.free_carrier import FreeCarrier
from vprobot.episode.part_scene import PartScene
from vprobot.episode.records import EpisodeRecord, ViewRecord, ViewRequest
from vprobot.episode.robot_carrier import RobotCarrier
from vprobot.episode.shared import SharedWork
from vprobot.episode.specs import (
    BUNDLED_TEST_EPISODES,
    EPISODE_LIST_VERSION,
    EpisodeSpec,
    episode_list,
    random_object_rotation,
    read_episode_list,
    sample_episode,
    seeded_episode,
    write_episode_list,
)

__all__ = [
    "BUNDLED_TEST_EPISODES",
    "CARRIERS",
    "EPISODE_LIST_VERSION",
    "Carrier",
    "CarrierName",
    "Episode",
    "EpisodeRecord",
    "EpisodeSpec",
    "FreeCarrier",
    "PartScene",
    "RobotCarrier",
    "SharedWork",
    "ViewRecord",
    "ViewRequest",
    "describe_cycle",
    "episode_list",
    "episode_moves",
    "make_carrier",
    "random_object_rotation",
    "read_episode_list",
    "sample_episode",
    "seeded_episode",
    "timed_cycle",
    "write_episode_list",
]
