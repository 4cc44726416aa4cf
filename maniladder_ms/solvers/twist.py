"""Unscrewing a lid in strokes with a top-down end effector (the UnscrewCap family, `objects.jar`): grip the
lid, turn the wrist counter-clockwise until Panda joint 7 nears its limit, let go, turn the open hand back,
grip again, until the task reports success.

The wrist turns at most ~0.04 rad a control step in `pd_ee_delta_pose` (the controller's 0.1 rad step
against the arm's PD lag), and joint 7 spans 5.8 rad, so a turn of more than ~300 degrees needs
regrasps. The loop is closed on the TCP's measured yaw (the target leads it by `LEAD`, less than pi, so
the orientation error never takes the short way back) and on joint 7, whose limits end each stroke.
"""

from __future__ import annotations

import torch

from maniladder_ms.geometry import matrix_yaw
from maniladder_ms.solvers.control import top_down_quat
from mani_skill.utils.geometry.rotation_conversions import quaternion_apply, quaternion_invert, quaternion_to_matrix

from .driven import DrivenSolver

J7_LIMIT = 2.8973  # rad, Panda joint 7's range is +-this
J7_MARGIN = 0.2  # each stroke stops this far from the limit
LEAD = 0.3  # rad the yaw target leads the measured yaw (the Driver turns at most 0.1 rad a step)
ABOVE_LID = 0.04  # m the open hand rises while it turns back
BACK_MARGIN = 0.3  # rad: the hand turns back for the rest of the turn plus this (the grip slips a little)


def tcp_yaw(s: DrivenSolver, arm: str) -> torch.Tensor:
    """(n,) yaw of a top-down TCP: the angle of its x axis about world z."""
    return matrix_yaw(quaternion_to_matrix(s.tcp(arm).q))


def wrist_angle(s: DrivenSolver, arm: str) -> torch.Tensor:
    """(n,) the arm's wrist joint (panda_joint7) angle: how far a stroke has wound it towards `J7_LIMIT`."""
    names = [j.name for j in s.agent.robot.active_joints]
    prefix = arm[: -len("arm")]
    return s.agent.robot.get_qpos()[:, names.index(f"{prefix}panda_joint7")]


def grip_target(position: torch.Tensor, yaw: torch.Tensor, offset=None):
    """(p, q) of a top-down TCP at yaw `yaw` (n,) whose grip point, `offset` (3,) in the TCP frame (None: the
    TCP itself), is at `position` (n, 3): turning the yaw swings the TCP round the grip point."""
    q = top_down_quat(yaw, position.shape[0], position.device)
    if offset is None:
        return position, q
    return position - quaternion_apply(q, torch.as_tensor(offset, device=position.device).expand_as(position)), q


def turn_wrist(s: DrivenSolver, arm: str, position, direction: int, stop, max_steps: int, offset=None, lead=None):
    """Turn a top-down TCP about the vertical through its grip point (`offset`, see `grip_target`) held at
    `position()` (n, 3), counter-clockwise from above for `direction` +1, as fast as the controller goes,
    until `stop()` (a bool) or `max_steps`; `lead()`, if given, is this step's (n,) lead instead of `LEAD`."""
    for _ in range(max_steps):
        if stop():
            return
        ahead = LEAD if lead is None else lead()
        s.step({arm: grip_target(position(), tcp_yaw(s, arm) + direction * ahead, offset)})


def wind_up_target(s: DrivenSolver, arm: str, position: torch.Tensor, offset=None):
    """This control step's target (p, q) of a top-down TCP whose grip point (`offset`, see `grip_target`)
    goes to `position` while its wrist turns clockwise (from above) to the start of joint 7's range, where
    a stroke begins; call it each step (it can run beside other arms' moves)."""
    wound = wrist_angle(s, arm) >= J7_LIMIT - J7_MARGIN
    return grip_target(position, tcp_yaw(s, arm) - torch.where(wound, 0.0, LEAD), offset)


def rise_first(s: DrivenSolver, arm: str, target: torch.Tensor) -> torch.Tensor:
    """This step's position target for a TCP going to `target` (n, 3) above a container: from below it
    (the rest pose's TCP is level with a lid top or lower), straight up first, so the fingers do not
    sweep into the container on the way."""
    tcp = s.tcp(arm).p
    rise = tcp[:, 2] < target[:, 2] - 0.02
    return torch.where(rise[:, None], torch.cat([tcp[:, :2], target[:, 2:]], dim=1), target)


def is_wound_up(s: DrivenSolver, arm: str) -> bool:
    return bool((wrist_angle(s, arm) >= J7_LIMIT - J7_MARGIN).all())


def lid_points(task):
    """Functions of no argument giving, now, the TCP grip point on the lid of `task.jar` (mid-height, on its
    axis) and the point `ABOVE_LID` above its top, (n, 3) each."""
    lid_h = task.jar_shape.lid_height
    down = torch.tensor([0.0, 0.0, lid_h / 2], device=task.device)
    up = torch.tensor([0.0, 0.0, ABOVE_LID], device=task.device)
    return (lambda: task.lid_top() - down), (lambda: task.lid_top() + up)


class HoldPosition:
    """An integral term on a TCP's position error: `at(goal)` (n, 3) is where to command the TCP so that it
    settles at `goal` against a steady load (the arm's IK-step controller leaves ~1 cm under a LEAP hand's
    weight, and a grip on a lid pushes the hand up as the wrist turns): each call adds `gain` times the last
    step's error, up to `limit` m."""

    def __init__(self, s: DrivenSolver, arm: str, gain: float, limit: float = 0.03):
        self.s, self.arm, self.gain, self.limit = s, arm, gain, limit
        self.bias = None

    def at(self, goal: torch.Tensor) -> torch.Tensor:
        """`goal` (n, 3): a TCP position, or a point that moves with the TCP (a grip point)."""
        tcp = self.s.tcp(self.arm).p
        if self.bias is None:
            self.bias = torch.zeros_like(tcp)
        else:  # the last step's target, less the bias, is where the TCP should have gone
            last = self.s.arm_targets[self.arm][0] - self.bias
            self.bias = (self.bias + self.gain * (last - tcp)).clamp(-self.limit, self.limit)
        return goal + self.bias


def unscrew(s: DrivenSolver, task, arm: str, ee: str, max_strokes: int = 4, stroke_steps: int = 200,
            offset=None, synergy: str | None = None, ramp_steps: int = 40, preshape: str | None = None,
            follow: float = 1.0, measured_axis: bool = False,
            rise_back: float | None = None, release_steps: int = 5, still_release: bool = False,
            back_margin: float = BACK_MARGIN, soft_end: bool = False,
            stop_on_release: bool = False, hold_gain: float = 0.0, release_pose=None):
    """Unscrew `task.jar`'s lid (UnscrewCapTask) in strokes with `arm` / `ee` (see the module docstring);
    the hand winds up first unless it already has (`wind_up_target`). `offset`: the grip point in the TCP
    frame (`grip_target`; None: the TCP); `synergy`: the LEAP grasp that grips the lid, closed over
    `ramp_steps` (None: `DrivenSolver.grasp`), from the hand posture `preshape` taken above the lid;
    `follow`: the share of the wrist's turn the lid takes (the rest slips), which sets how far the open
    hand turns back for the rest of the turn; `measured_axis`: each stroke turns the closed hand about the
    lid's axis as it stands once the hand has closed, the hand keeping its grip on it as it then is (for a
    container held by another hand, which gives a little as the hand closes: turning about the planned grip
    point would drag the lid round a circle and tip the container), not about the planned grip point;
    `rise_back`: the opened hand first rises to this height (m) above the lid's top, then turns back there
    (None: it turns back as it rises to `ABOVE_LID`; on a held container, which tilts a little in its
    holder's grip, the hanging thumb then dragged the lid back); `release_steps`: control steps the hand
    opens over after a stroke; `still_release`: the arm holds the TCP where it is while the hand opens
    (otherwise it keeps turning to the stroke's last target, which leads by `LEAD`: on a held container
    the opening hand then spun it in its holder's grip); `back_margin`: how much further (rad) than the
    rest of the turn the open hand turns back (a regrasp on a lid off its home stop turns it back a little
    as the hand closes); `soft_end`: the stroke's yaw target leads by no more than joint 7 has left before
    the stroke's end (with `LEAD` past it, the arm's other joints turned the TCP on, and off the lid's axis,
    tipping a held container); `stop_on_release`: stop if the task succeeds as the hand lets go (the last
    bit of the turn can come with the opening hand; a needless regrasp then risked the held container);
    `hold_gain`: the gain of a `HoldPosition` integral on the TCP's position while the hand reaches the lid,
    closes on it and turns it (0: none); `release_pose`: the hand posture (joint targets) the hand opens to
    after a stroke and keeps while it turns back (None: "open", the flat hand)."""
    release = float(torch.deg2rad(torch.tensor(float(task.release_angle))))
    grip_point, above = lid_points(task)

    def done():
        return bool(s.info.get("success", torch.zeros(1, dtype=torch.bool)).all())

    s.release(ee, steps=0)
    for _ in range(80):
        if is_wound_up(s, arm):
            break
        s.step({arm: wind_up_target(s, arm, above(), offset)})
    for _ in range(max_strokes):
        if preshape is not None:
            s.set_ee(ee, preshape, steps=5)
        held = None  # the arm's targets while the hand closes: None, or the hold's correction of the reached grip
        if hold_gain > 0:
            hold = HoldPosition(s, arm, hold_gain)
            yaw = tcp_yaw(s, arm)
            reached = {}  # the last grip target the reach commanded
            held = lambda: {arm: (hold.at(reached["p"]), reached["q"])}  # noqa: E731  (that target, held)

            def held_grip():  # the grip target as the lid now stands, held
                reached["p"], reached["q"] = grip_target(grip_point(), yaw, offset)
                return held()

            s.move(held_grip, max_steps=30, pos_tol=0.0)  # all 30 steps (no tolerance): the hold's integral settles
        else:
            s.move({arm: grip_target(grip_point(), tcp_yaw(s, arm), offset)}, max_steps=30, pos_tol=0.003)
        if synergy is None:
            s.grasp(ee)
        else:
            s.close_hand(ee, synergy, ramp_steps=ramp_steps, arm_targets=held)
        axis, grip = grip_point, offset
        if measured_axis:
            point = grip_point()
            tcp = s.tcp(arm)
            grip = quaternion_apply(quaternion_invert(tcp.q), point - tcp.p)  # the lid's axis point in the TCP frame
            axis = lambda: point  # noqa: E731
        ahead = (lambda: (wrist_angle(s, arm) + J7_LIMIT - J7_MARGIN).clamp(0.05, LEAD)) if soft_end else None
        if hold_gain > 0:
            axis_point = axis
            axis = lambda: hold.at(axis_point())  # noqa: E731  (a shift of the grip point shifts the TCP alike)
        turn_wrist(s, arm, axis, 1, lambda: done() or bool((wrist_angle(s, arm) <= -J7_LIMIT + J7_MARGIN).all()),
                   max_steps=stroke_steps, offset=grip, lead=ahead)
        if done():
            return
        if still_release:
            tcp = s.tcp(arm)
            s.arm_targets[arm] = (tcp.p.clone(), tcp.q.clone())
        if release_pose is None:
            s.release(ee, steps=release_steps)
        else:
            s.set_ee(ee, release_pose, steps=release_steps)
        if stop_on_release and done():
            return
        back = above
        if rise_back is not None:
            high = task.lid_top() + torch.tensor([0.0, 0.0, rise_back], device=task.device)
            back = lambda: high  # noqa: E731
            s.move({arm: grip_target(high, tcp_yaw(s, arm), offset)}, max_steps=25, pos_tol=0.01)
        # turn back as far as the rest of the turn needs (or the wrist allows)
        back_to = wrist_angle(s, arm) + ((release - task.memory["held_turn"][:, 0]) / follow + back_margin)
        turn_wrist(s, arm, back, -1,
                   lambda: bool(((wrist_angle(s, arm) >= back_to)
                                 | (wrist_angle(s, arm) >= J7_LIMIT - J7_MARGIN)).all()),
                   max_steps=stroke_steps, offset=offset)
