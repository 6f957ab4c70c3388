"""The plan JSON (docs/plan-format.md): written from an episode (`document`), read back with
the cell it was made for (`reader`), field by field (`fields`)."""

from vprobot.plan.document import (
    episode_document,
    plan_document,
    planned_views,
    view_entry,
    write_json,
)
from vprobot.plan.fields import plan_array, plan_field, plan_number, plan_quaternion, plan_vector
from vprobot.plan.reader import plan_carrier, plan_config, plan_object, plan_robot, read_plan

__all__ = [
    "episode_document",
    "plan_array",
    "plan_carrier",
    "plan_config",
    "plan_document",
    "plan_field",
    "plan_number",
    "plan_object",
    "plan_quaternion",
    "plan_robot",
    "plan_vector",
    "planned_views",
    "read_plan",
    "view_entry",
    "write_json",
]
