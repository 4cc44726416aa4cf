"""Issue 20's open choice, measured: is a Level-1 task out of the reference policy's reach because 20 demos cannot
cover its randomisation? This pilot draws a task's layout from a narrower randomisation (the registered task is not
changed: its `_initialize_episode` is wrapped in this process only) and runs, on it, either

- `--oracle`: 20 solver demos of the variant, then the state oracle (`scripts/state_oracle.py`: the same LadderFlow
  network on privileged state) evaluated on 20 selection seeds of the same variant; or
- `--visual`: the whole calibration protocol of `maniladder calibrate` (demos, features, train 8000 steps, select,
  50 evaluation episodes) on the variant.

`--scale S` shrinks every uniform draw of the task's layout (`torch.rand` inside its `_initialize_episode`) about
the middle of its range by S, so each range keeps its centre and is S times as wide; a 50/50 choice stays 50/50.
`--one-side` (PickPlacePen only) also puts the pen always on the robot's left (+y) and the tray on its right.

    python scripts/randomisation_pilot.py PickPlacePen --scale 0.5 --one-side --oracle   # ~15 min on one core
    python scripts/randomisation_pilot.py PickPlacePen --scale 0.5 --one-side --visual   # ~35 min; resumable
    python scripts/randomisation_pilot.py HangMug --scale 0.5 --visual
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np
import torch

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))
sys.path.insert(0, str(REPO / "scripts"))


def shrink_layout_draws(task_id: str, scale: float) -> None:
    """Wrap `task_id`'s `_initialize_episode` in this process so that each `torch.rand` draw u becomes
    0.5 + (u - 0.5) * scale: every uniform range keeps its middle and is `scale` times as wide."""
    from mani_skill.utils.registration import REGISTERED_ENVS

    from maniladder_ms import default_catalog

    cls = REGISTERED_ENVS[default_catalog().get(task_id).env_id].cls
    registered = cls._initialize_episode

    def _initialize_episode(self, env_idx, options):
        rand = torch.rand
        torch.rand = lambda *a, **k: 0.5 + (rand(*a, **k) - 0.5) * scale
        try:
            registered(self, env_idx, options)
        finally:
            torch.rand = rand

    cls._initialize_episode = _initialize_episode


def pick_place_pen_one_side(scale: float) -> None:
    """Replace PickPlacePen's layout draw in this process: the registered task's ranges (its catalog params
    `pen_x_range` and the rest, drawn in its `_initialize_episode`'s order), each scaled by `scale` about its middle,
    the pen on the robot's left (+y) and the tray on its right. Since the layout policy's rule 1 the row itself is
    one-sided this way, so this is the row's own draw scaled; the committed pilot result was measured on the
    two-sided row's ranges halved, which are today's row's ranges but for the tray's yaw (halved in the pilot)."""
    from mani_skill.utils.structs.pose import Pose

    from maniladder_ms.envs import ManiLadderEnv
    from maniladder_ms.geometry import yaw_quat
    from maniladder_ms.tasks.rigid.pick_place_pen import PickPlacePenEnv

    def _initialize_episode(self, env_idx, options):
        ManiLadderEnv._initialize_episode(self, env_idx, options)
        with torch.device(self.device):
            b = len(env_idx)

            def uniform(lo, hi):
                return (lo + hi) / 2 + (torch.rand(b) - 0.5) * (hi - lo) * scale

            pen_xyz = torch.stack([uniform(*self.pen_x_range), uniform(*self.pen_y_range),
                                   torch.full((b,), self.pen_radius)], 1)
            self.pen.set_pose(Pose.create_from_pq(pen_xyz, yaw_quat(uniform(*np.deg2rad(self.pen_yaw_range)))))
            tray_xyz = torch.stack([uniform(*self.tray_x_range), uniform(*self.tray_y_range), torch.zeros(b)], 1)
            max_yaw = np.deg2rad(self.tray_max_yaw)
            self.tray.set_pose(Pose.create_from_pq(tray_xyz, yaw_quat(uniform(-max_yaw, max_yaw))))

    PickPlacePenEnv._initialize_episode = _initialize_episode


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("task")
    ap.add_argument("--scale", type=float, default=0.5, help="width of every layout range, as a fraction of the task's")
    ap.add_argument("--one-side", action="store_true", help="PickPlacePen: the pen always on the left, the tray right")
    mode = ap.add_mutually_exclusive_group(required=True)
    mode.add_argument("--oracle", action="store_true", help="20 demos, then the state oracle on 20 selection seeds")
    mode.add_argument("--visual", action="store_true", help="the whole calibration protocol on the variant")
    ap.add_argument("--work", default="runs/randomisation_pilot", help="demos and calibration folders go here")
    ap.add_argument("--steps", type=int, default=6000, help="--oracle: training steps")
    args = ap.parse_args(argv)

    if not 0 < args.scale <= 1:
        ap.error(f"--scale {args.scale}: give a fraction in (0, 1]")
    if args.one_side and args.task != "PickPlacePen":
        ap.error("--one-side is PickPlacePen's (its pen on the left, its tray on the right)")
    torch.set_num_threads(1)
    if args.one_side:
        pick_place_pen_one_side(args.scale)
    else:
        shrink_layout_draws(args.task, args.scale)
    from maniladder_ms.demos.files import demo_path
    from maniladder_ms.demos.recording import generate
    from maniladder_ms.policy.calibrate import CalibrationProtocol, TaskCalibration, demo_control_mode_for

    variant = f"{args.task}_scale{args.scale:g}" + ("_one_side" if args.one_side else "")
    work = Path(args.work) / variant
    protocol = CalibrationProtocol(purpose="development")  # a pilot informs a decision: development seeds
    h5 = demo_path(work / "demos", args.task, "none", demo_control_mode_for(args.task))
    if not h5.is_file():  # the protocol's demos: seeds from its demo seed, in the calibration's control mode
        generate(args.task, protocol.demos, work / "demos", seed=protocol.demo_seed, control_mode=demo_control_mode_for(args.task))
    if args.oracle:
        import state_oracle

        state_oracle.main([args.task, "--demo-file", str(h5), "--num-demos", str(protocol.demos), "--steps", str(args.steps)])
    else:
        r = TaskCalibration(args.task, work=work / "calibration", out=work / "result", demos_dir=work / "demos",
                            protocol=protocol).run()
        result = work / "result" / f"{args.task}.json"  # labelled: not the registered task's calibration
        r["randomisation_pilot"] = {"scale": args.scale, "one_side": args.one_side,
                                    "note": "layout drawn from a narrowed randomisation, not the registered task's"}
        result.write_text(json.dumps(r, indent=1))
        print(f"VISUAL {variant}: {r['successes']}/{r['episodes']} ({100 * r['success']:.0f}%, 95% "
              f"[{100 * r['ci95'][0]:.0f}, {100 * r['ci95'][1]:.0f}]), development seeds")


if __name__ == "__main__":
    main()
