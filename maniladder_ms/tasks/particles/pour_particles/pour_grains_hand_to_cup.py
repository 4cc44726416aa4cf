"""PourGrainsHandToCup (L1 deformable DX): one LEAP hand holds a cup, the other pours grains into it from a glass."""

from __future__ import annotations

from typing import Any

import numpy as np
import torch

from maniladder_ms.deformables import particles
from .base import CupToBowl
from maniladder_ms.envs import ManiLadderEnv, register_task
from maniladder_ms.objects import containers
from maniladder_ms.solvers import TCP_DELTA_MODES, register_solver
from maniladder_ms.solvers.bimanual import READY_ARM_JOINTS, Grasp, close_hands, glide, side_grasp
from maniladder_ms.solvers.driven import DrivenSolver
from maniladder_ms.solvers.pouring import steer_roll

# The left hand pours and the right holds. Both take side grasps, palm level with the container, the finger row
# upright. The pourer's grasp needs its thumb low, under the glass' grains. For the right Panda that grasp puts
# joint 7 at 2.88 of its 2.90 rad limit: pinocchio IK finds no other solution with the elbow up, and servoing to
# it left the arm 0.5-0.6 rad short on ~30 % of seeds. For the left Panda, joint 7 is at -1.4 rad, with >= 0.8 rad
# to every limit over the reach, carry and roll. The right hand holds the cup with its thumb high (margin 0.96).
POURER, HOLDER = "left", "right"
# the ready pose (`solvers.bimanual.READY_ARM_JOINTS`): each hand raised above its container, turned for its side
# grasp (the pourer's with the thumb low, the holder's high)


@register_task("PourGrainsHandToCup")
class PourGrainsHandToCupEnv(CupToBowl, ManiLadderEnv):
    """**Task:** the right LEAP hand holds a cup standing on the table while the left LEAP hand picks up a
    glass of grains and pours them into the cup.

    **Randomisation:**
    - the cup (plastic, inner radius 3.5 cm, 11 cm tall, 7.8 cm wide outside) stands in front of the right
      arm, x in [-0.06, 0], y in [-0.06, 0];
    - the glass (inner radius 2.7 cm at the floor widening to 2.9 cm at the rim, 13 cm tall) stands to the
      left behind it, x in [-0.16, -0.1], y in [0.14, 0.2], holding 60 grains (granular spheres, radius 4 mm)
      packed from its floor with a small random jitter;
    - the arms start in a ready pose (`READY_JOINTS`, plus the usual joint noise): each hand raised above its
      container, palm turned in for a side grasp.

    **Success:** (`CupToBowl.held_pour_metrics`, the PourParticles rule) at least `success_fraction` of the
    `particle_count` grains lie inside the cup's inner volume (below its rim, `particles.fraction_inside`); the right hand
    holds the cup (`cup_held`, `ee.holds`: a finger against the thumb or palm, or the scissor pinch) and
    the left hand the glass (`glass_grasped`), now and on every step since the first grain landed in the
    cup (episode memory `cup_let_go`, `glass_let_go`): the grains go into the held cup, poured from the
    held glass.

    (In `CupToBowl`'s terms the glass is the pouring `self.cup` and the held cup the receiving `self.bowl`.)
    """

    SUPPORTED_ROBOTS = ["ml_dual_panda_leap"]
    max_dense_reward = 6
    TASK_REGION = (-0.25, 0.12, -0.25, 0.25)
    READY_JOINTS = {f"{side}_panda_joint{i}": angle for side in (POURER, HOLDER)
                    for i, angle in enumerate(READY_ARM_JOINTS[side], 1)}
    # tall enough for the LEAP hand's side grasp: the thumb closes low on it, the three fingers above
    cup_shape = containers.glass(bottom_radius=0.027, top_radius=0.029, height=0.13)
    bowl_shape = containers.cup(radius=0.035, height=0.11, wall=0.004)
    cup_name = "glass"
    bowl_name = "cup"
    PARAMS = ("success_fraction", "particle_count")
    particle_name = "grains"
    # the receiving cup (`self.bowl`) by the holder, the pouring glass (`self.cup`) by the pourer
    held_containers = {"bowl": HOLDER, "cup": POURER}
    bowl_density = CupToBowl.cup_density  # a light plastic cup, as the glass
    bowl_color = (0.8, 0.35, 0.3, 1)
    placement = {"bowl": ((-0.06, 0.0), (-0.06, 0.0)), "cup": ((-0.16, -0.1), (0.14, 0.2))}

    particle_material = particles.GRANULAR
    particle_radius = 0.004

    def _get_obs_extra(self, info: dict):
        obs = dict(left_tcp_pose=self.ee.tcp("left").raw_pose, right_tcp_pose=self.ee.tcp("right").raw_pose,
                   cup_held=info["cup_held"], glass_grasped=info["glass_grasped"])
        if "state" in self.obs_mode:
            obs.update(self._cup_and_bowl_obs())
        return obs

    def evaluate(self):
        metrics = self.held_pour_metrics()  # cup_held, glass_held, cup_let_go, glass_let_go
        return {
            **metrics,
            "fraction_in_held_cup": metrics["fraction_in_bowl"],
            "fraction_in_glass": metrics["fraction_in_cup"],
            "glass_grasped": metrics["glass_held"],
            "glass_lifted": self.cup.pose.p[:, 2] > 0.05,
        }

    def compute_dense_reward(self, obs: Any, action: torch.Tensor, info: dict):
        # holder: reach and hold the cup; pourer: reach the glass, grasp, lift, carry beside the cup; then the
        # grains in the cup
        mid = torch.tensor([0, 0, 0.04], device=self.device)
        reach_cup = 1 - torch.tanh(5 * torch.linalg.norm(self.bowl.pose.p + mid - self.ee.tcp(HOLDER).p, dim=1))
        reach_glass = 1 - torch.tanh(5 * torch.linalg.norm(self.cup.pose.p + mid - self.ee.tcp(POURER).p, dim=1))
        grasped = info["glass_grasped"].float()
        carry = 1 - torch.tanh(5 * torch.linalg.norm((self.bowl.pose.p - self.cup.pose.p)[:, :2], dim=1))
        reward = 0.5 * (reach_cup + info["cup_held"].float()) + 0.5 * reach_glass + grasped
        reward += carry * grasped * info["glass_lifted"]
        reward += 2 * self.pour_reward(info) * info["cup_held"]
        reward[info["success"]] = self.max_dense_reward
        return reward


# Side grasps: the palm normal's yaw, its tilt below the horizontal, which way the finger row runs (the TCP's y
# along +-z: the pourer's thumb low, the holder's high), the TCP's height above the container's floor, and its
# shifts along the TCP's x (towards where the fingers start to curl) and along the palm normal (past the axis).
SIDE_GRASP = {
    # the glass: LEAP "power"'s fingers with the thumb joints beyond its base only slightly bent ("power"'s 0.6 /
    # 0.8 / 0.8 pushed the standing glass over by ~30 deg while closing)
    POURER: dict(yaw=-np.pi / 2, pitch=0.0, up=-1.0, height=0.06, shift=0.04, inwards=0.0,
                 approach="preshape", close=np.array([0.0, 1.5, 0.6, 0.4] * 3 + [1.6, 0.3, 0.3, 0.3])),
    # the cup, palm tilted 0.3 rad down: "power"'s fingers and the thumb swung in 1 rad, straight, pressing the
    # cup's near side below the rim (seeds 106/107/109/110: fingers only held by one fingertip and a flickering
    # palm contact, the cup counted held on 8 of 15 seeds; a thumb swung 0.6 or curled at its outer joints reached
    # over the rim and 18-55 % of the grains got in; this thumb: 3/4, thumb 8-38 N, three fingertips 6-14 N).
    # The hand comes in open: "preshape"'s swung thumb met the cup first and tilted it 17-24 deg. Its row's
    # lowest finger clears the table at a TCP height of 7.5 cm
    HOLDER: dict(yaw=np.pi / 2, pitch=0.3, up=-1.0, height=0.075, shift=0.02, inwards=0.035,
                 approach="open", close=np.array([0.0, 1.5, 0.6, 0.4] * 3 + [1.0, 0.0, 0.0, 0.0])),
}
LINE_UP_DISTANCE = 0.1  # along the palm normal, before moving in
ABOVE = 0.1  # the first target: this far above the line-up point (the ready pose is there)
# the pourer's thumb swings under its palm before the descent: open, it hangs ~11 cm below the TCP and met the
# table at the line-up; swung for 5 steps only, the glass then pivoted 30-45 deg in the carry
PRESHAPE_STEPS = 20
LIFT = 0.1
CARRY_STEP = 0.01  # m per control step
CARRY_BESIDE = 0.08  # the upright glass' axis this far from the cup's, against the pour direction
# the glass' bottom above the table while carried, and the mouth's height at the end of the roll: with 0.14 /
# 0.16 the glass and the pourer's fingers hit the holder's hand (held on 1 of 5 seeds), with 0.18 / 0.19 4 of 5
CARRY_BOTTOM, MOUTH_HEIGHT = 0.18, 0.19
# rad about the pourer's palm normal (-y): this sign tips the mouth towards the robot (-x), turning the left
# Panda's joint 7 from -1.5 to ~1.0 rad (the other sign would need -3.9, past its limit)
POUR_ROLL, POUR_ROLL_STEPS, POUR_HOLD_STEPS = 2.4, 70, 60
CLEAR = 0.02  # the glass' lower bottom edge clears the cup's rim by this during the roll


@register_solver("PourGrainsHandToCup", control_modes=TCP_DELTA_MODES)
def solve_pour_grains_hand_to_cup(env, seed: int) -> dict:
    """Both hands line up beside their containers from the ready pose and move in; the holder closes on the
    cup, the pourer on the glass, lifts it, carries it upright beside the cup and rolls it over the cup."""
    with DrivenSolver.episode(env, seed) as s:
        task: PourGrainsHandToCupEnv = env.unwrapped
        grasps, normals = [], {}
        for side, vessel in ((HOLDER, task.bowl), (POURER, task.cup)):
            p, q, normals[side] = side_grasp(vessel.pose.p, SIDE_GRASP[side])
            grasps.append(Grasp(f"{side}_arm", f"{side}_hand", p, q, -LINE_UP_DISTANCE * normals[side]))
        s.move({g.arm: (s.above(g.lined_up[0], ABOVE), g.q) for g in grasps}, max_steps=60, pos_tol=0.01)
        for g, side in zip(grasps, (HOLDER, POURER)):
            s.set_ee(g.ee, SIDE_GRASP[side]["approach"], steps=0)
        for _ in range(PRESHAPE_STEPS):
            s.step()
        s.move({g.arm: g.lined_up for g in grasps}, max_steps=60)
        s.move({g.arm: (g.p, g.q) for g in grasps}, max_steps=40, pos_tol=0.003)
        close_hands(s, {g.ee: SIDE_GRASP[side]["close"] for g, side in zip(grasps, (HOLDER, POURER))})
        glass = grasps[1]
        s.move({glass.arm: (s.above(glass.p, LIFT), glass.q)}, max_steps=30)
        # the roll tips the mouth along palm normal x up: carry the glass to the cup's other side
        direction = torch.linalg.cross(normals[POURER], torch.tensor([[0.0, 0.0, 1.0]], device=task.device).expand_as(glass.p))
        held = s.tcp(glass.arm).p - task.cup.pose.p  # the TCP relative to the glass' bottom, as held
        carry = task.bowl.pose.p - CARRY_BESIDE * direction + held
        carry[:, 2] = CARRY_BOTTOM + held[:, 2]
        glide(s, {glass.arm: (s.tcp(glass.arm).p, carry, glass.q)}, step_length=CARRY_STEP)
        # roll the glass about the palm normal, its mouth steered to MOUTH_HEIGHT over the cup, its bottom edge
        # clearing the cup's rim
        end = task.bowl.pose.p.clone()
        end[:, 2] = MOUTH_HEIGHT
        rim_z = torch.full((task.num_envs,), task.bowl_shape.inner[-1][0], device=task.device)
        steer_roll(s, task, glass.arm, normals[POURER], glass.q, end, rim_z, POUR_ROLL, POUR_ROLL_STEPS,
                   POUR_HOLD_STEPS, CLEAR)
        s.hold_until_success(max_steps=40)
        return s.info
