"""Demonstrations: scripted solvers recorded as ManiSkill h5 + json trajectories.

Files are ManiSkill-standard (`RecordEpisode` output) so ManiSkill's own tools work on them, e.g.
`python -m mani_skill.trajectory.replay_trajectory`. Layout of a dataset folder:

    <out>/<TaskId>/trajectory.<obs_mode>.<control_mode>.physx_cpu.h5   (+ .json)

named as ManiSkill names converted datasets (<name>.<obs_mode>.<control_mode>.<sim_backend>); the
default obs mode is `none`, and a replay into rgbd writes `trajectory.rgbd.<control_mode>.physx_cpu.h5`
beside it.
"""

from .files import DemoFileError, load_demo_json, open_demo_h5
from .metadata import copy_metadata
from .recording import generate
from .stats import dataset_stats
from .verify import verify
