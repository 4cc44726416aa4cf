"""Issue 20's open choice, measured: is a Level-1 task out of the reference policy's reach because 20 demos cannot
cover its randomisation? This pilot re-draws PickPlacePen's layout from a narrower randomisation (the registered
task is not changed: its `_initialize_episode` is replaced in this process only) and runs, on it, either

- `--oracle`: 20 solver demos of the variant, then the state oracle (`scripts/state_oracle.py`: the same LadderFlow
  network on privileged state) evaluated on 20 selection seeds of the same variant; or
- `--visual`: the whole calibration protocol of `maniladder calibrate` (demos, features, train 8000 steps, select,
  50 evaluation episodes) on the variant.

Variants (ranges as `PickPlacePenEnv`'s docstring gives them; "side" = the pen on a random side of the robot's
centre line and the tray opposite):

    full      the registered task: both sides, full ranges
    side      the pen always on the robot's left (+y), the tray on its right; full ranges
    half      one side, and every range (pen x, |y|, yaw; tray x, |y|, yaw) halved about its middle

    python scripts/randomisation_pilot.py half --oracle      # ~15 min on one core
    python scripts/randomisation_pilot.py half --visual      # ~1.5 h on one core; resumable
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
import torch

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))
sys.path.insert(0, str(REPO / "scripts"))

VARIANTS = {  # name: (pen always on one side, scale of every range about its middle)
    "full": (False, 1.0),
    "side": (True, 1.0),
    "half": (True, 0.5),
}
TASK = "PickPlacePen"


def narrow_pick_place_pen(one_side: bool, scale: float) -> None:
    """Replace PickPlacePen's layout draw in this process: the same ranges as the registered task's, each scaled
    by `scale` about its middle, the pen on the left (+y) only if `one_side`."""
    from mani_skill.utils.structs.pose import Pose

    from maniladder_ms.envs import ManiLadderEnv
    from maniladder_ms.geometry import yaw_quat
    from maniladder_ms.tasks.pick_place_pen import PickPlacePenEnv

    def _initialize_episode(self, env_idx, options):
        ManiLadderEnv._initialize_episode(self, env_idx, options)
        with torch.device(self.device):
            b = len(env_idx)
            side = torch.ones(b) if one_side else torch.where(torch.rand(b) < 0.5, -1.0, 1.0)

            def uniform(lo, hi):
                return (lo + hi) / 2 + (torch.rand(b) - 0.5) * (hi - lo) * scale

            pen_xyz = torch.stack([uniform(-0.12, 0.08), side * uniform(0.06, 0.2), torch.full((b,), self.pen_radius)], 1)
            self.pen.set_pose(Pose.create_from_pq(pen_xyz, yaw_quat(uniform(0, np.pi))))
            tray_xyz = torch.stack([uniform(-0.1, 0.1), -side * uniform(0.1, 0.2), torch.zeros(b)], 1)
            self.tray.set_pose(Pose.create_from_pq(tray_xyz, yaw_quat(uniform(-np.pi / 4, np.pi / 4))))

    PickPlacePenEnv._initialize_episode = _initialize_episode


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("variant", choices=sorted(VARIANTS))
    mode = ap.add_mutually_exclusive_group(required=True)
    mode.add_argument("--oracle", action="store_true", help="20 demos, then the state oracle on 20 selection seeds")
    mode.add_argument("--visual", action="store_true", help="the whole calibration protocol on the variant")
    ap.add_argument("--work", default="runs/randomisation_pilot", help="demos and calibration folders go here")
    ap.add_argument("--steps", type=int, default=6000, help="--oracle: training steps")
    args = ap.parse_args(argv)

    torch.set_num_threads(1)
    narrow_pick_place_pen(*VARIANTS[args.variant])
    from maniladder_ms.demos.files import demo_path
    from maniladder_ms.demos.recording import generate
    from maniladder_ms.policy.calibrate import CalibrationProtocol, TaskCalibration, demo_control_mode_for

    work = Path(args.work) / args.variant
    protocol = CalibrationProtocol()
    h5 = demo_path(work / "demos", TASK, "none", demo_control_mode_for(TASK))
    if not h5.is_file():  # the protocol's demos: seeds from its demo seed, in the calibration's control mode
        generate(TASK, protocol.demos, work / "demos", seed=protocol.demo_seed, control_mode=demo_control_mode_for(TASK))
    if args.oracle:
        import state_oracle

        state_oracle.main([TASK, "--demo-file", str(h5), "--num-demos", str(protocol.demos), "--steps", str(args.steps)])
    else:
        r = TaskCalibration(TASK, work=work / "calibration", out=work / "result", demos_dir=work / "demos").run()
        print(f"VISUAL {args.variant}: {r['successes']}/{r['episodes']} ({100 * r['success']:.0f}%, 95% "
              f"[{100 * r['ci95'][0]:.0f}, {100 * r['ci95'][1]:.0f}]), selection {r['selection']['selection_rates']}")


if __name__ == "__main__":
    main()
