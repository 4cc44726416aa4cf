"""`maniladder demos copy-meta`: put back what ManiSkill's `replay_trajectory` leaves out of a converted demo's json.

A conversion (`replay_trajectory --traj-path SOURCE.h5 -o rgbd --save-traj`, or `-c MODE`) writes a new h5/json
pair through ManiSkill's `RecordEpisode`, whose json holds only ManiSkill's own fields. Dropped from ours:

- `env_info.env_id`'s `maniladder_ms:` prefix (the converted id is the bare `ManiLadder-<TaskId>-v1`, which
  `gym.make` finds only after `import maniladder_ms`);
- each episode's language `instruction`, and the top-level `instructions` (canonical or paraphrase);
- the top-level `solver` (the recording's attempts and successes), `source_type` and `source_desc`.

`copy_metadata` copies them from the source json onto the converted one, matching episodes by episode seed (a
conversion keeps the seeds, renumbers episode ids when it skips failed replays).
"""

from __future__ import annotations

import json
from pathlib import Path

from .files import ENV_ID_PREFIX, DemoFileError, json_path, load_demo_json, read_trajectory_json

EPISODE_FIELDS = ("instruction",)
TOP_FIELDS = ("instructions", "solver", "source_type", "source_desc")


def _task_of(env_id: str) -> str:
    return env_id.removeprefix(ENV_ID_PREFIX)


def copy_metadata(source_h5: Path, converted_h5: Path) -> int:
    """Copy the fields `replay_trajectory` drops (module docstring) from the json of the demo `source_h5` onto the
    json of its conversion `converted_h5`, in place; returns the number of episodes labelled. Refuses, changing
    nothing, a converted file of another task, an episode seed the source lacks, or a field the converted json
    already holds with another value."""
    source_h5, converted_h5 = Path(source_h5), Path(converted_h5)
    if source_h5.resolve() == converted_h5.resolve():
        raise DemoFileError(f"{converted_h5}: the source and the converted file are the same file")
    source = load_demo_json(source_h5)
    source.pop("task_spec")
    source.setdefault("instructions", "canonical")  # as load_demo_json reads files older than instructions
    path, converted = read_trajectory_json(converted_h5)
    task, converted_task = _task_of(source["env_info"]["env_id"]), _task_of(converted["env_info"].get("env_id", ""))
    if converted_task != task:
        raise DemoFileError(f"{path}: a demo of {converted_task or 'no env id'}, not of {task} as {source_h5} is")

    by_seed = {}
    for ep in source["episodes"]:
        if ep["episode_seed"] in by_seed:
            raise DemoFileError(f"{json_path(source_h5)}: episode seed {ep['episode_seed']} twice; "
                                "episodes cannot be matched by seed")
        by_seed[ep["episode_seed"]] = ep

    def put(where: dict, key: str, value, what: str):
        if key in where and where[key] != value:
            raise DemoFileError(f"{path}: {what} already has {key} {where[key]!r}, not the source's {value!r}; "
                                "nothing changed")
        where[key] = value

    for ep in converted["episodes"]:
        seed = ep.get("episode_seed")
        if seed not in by_seed:
            raise DemoFileError(f"{path}: episode {ep.get('episode_id')} (seed {seed}) is not in "
                                f"{json_path(source_h5)}; nothing changed")
        for key in EPISODE_FIELDS:
            if key in by_seed[seed]:
                put(ep, key, by_seed[seed][key], f"episode {ep.get('episode_id')} (seed {seed})")
    for key in TOP_FIELDS:
        if key in source:
            put(converted, key, source[key], "the json")
    converted["env_info"]["env_id"] = ENV_ID_PREFIX + converted_task

    tmp = path.with_name(path.name + ".partial")
    tmp.write_text(json.dumps(converted, indent=2))
    tmp.replace(path)
    return len(converted["episodes"])
