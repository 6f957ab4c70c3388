"""Write the episode lists that the bundled splits define (configs/episodes/validation-v1.json,
validation-v2.json and families-test-v1.json) with the shared sampler; tests/test_splits.py
checks they are what it draws."""

from __future__ import annotations

from vprobot.config import Config
from vprobot.episode import write_episode_list
from vprobot.episode.specs import bundled_episode_list, split_lists
from vprobot.parts.splits import Split, split_versions


def main() -> None:
    lists = {name: specs for version in split_versions()
             for name, specs in split_lists(Config(), Split.bundled(version)).items()}
    for name, specs in lists.items():
        print(write_episode_list(bundled_episode_list(name), specs), len(specs), "episodes")


if __name__ == "__main__":
    main()
