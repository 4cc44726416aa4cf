"""ScrewNutOnBolt's thread (objects/bolt.py) and its rule's guard: only a held turn of a raised bolt counts."""

import numpy as np
import sapien
import torch

import maniladder_ms
from maniladder_ms.objects.bolt import hex_ring_boxes, nut_advance, nut_angle


def _inside(point, boxes) -> bool:
    for pose, half in boxes:
        local = pose.inv() * sapien.Pose(p=point)
        if all(abs(c) <= h + 1e-9 for c, h in zip(local.p, half)):
            return True
    return False


def test_hex_ring_boxes_make_a_hex_prism_around_its_bore():
    across, height, bore = 0.028, 0.014, 0.009
    boxes = hex_ring_boxes(across, height, bore)
    corner = across / np.sqrt(3)  # the hexagon's corners lie this far from the axis
    for k in range(6):
        a = np.pi / 3 * k
        flat = np.array([np.cos(a), np.sin(a)])
        at_corner = np.array([np.cos(a + np.pi / 6), np.sin(a + np.pi / 6)])
        assert _inside([*(0.999 * across / 2 * flat), height / 2], boxes)  # just inside a flat
        assert not _inside([*(1.001 * across / 2 * flat), height / 2], boxes)  # just outside it
        assert _inside([*(0.999 * corner * at_corner), height / 2], boxes)  # a corner is filled
        assert not _inside([*(0.999 * bore * flat), height / 2], boxes)  # the bore is open
    assert not _inside([0.0, 0.0, height / 2], boxes)


def test_nut_advance_follows_its_turn_and_an_unheld_turn_does_not_count():
    env = maniladder_ms.make("ScrewNutOnBolt", obs_mode="state", control_mode="pd_ee_delta_pose")
    try:
        env.reset(seed=0)
        task = env.unwrapped
        hold = torch.zeros(env.action_space.shape)
        # the nut turned on well past the required advance, with no gripper on the bolt or the nut
        turn = 2 * np.pi * task.min_advance / task.thread_pitch + 1.0
        task.fastener.set_qpos(torch.tensor([[0.0, turn]]))
        task.fastener.set_qvel(torch.zeros(1, 2))
        for _ in range(10):
            *_, info = env.step(hold)
        # the thread's friction holds the angle; the carriage has followed it down the shaft (the thread's lead)
        assert abs(float(nut_angle(task.fastener)[0]) - turn) < 0.02
        expected = turn * task.thread_pitch / (2 * np.pi)
        assert abs(float(nut_advance(task.fastener)[0]) - expected) < 5e-4
        assert float(info["nut_advance"][0]) >= task.min_advance
        # ... but nothing held the bolt up and the nut while it turned: no held advance, no success
        assert float(info["held_advance"][0]) == 0.0
        assert not bool(info["screwing"][0]) and not bool(info["success"][0])
        # turned back to the start, the nut runs back up; its start is the thread's lower limit
        task.fastener.set_qpos(torch.zeros(1, 2))
        task.fastener.set_qvel(torch.tensor([[0.0, -2.0]]))
        for _ in range(5):
            env.step(hold)
        assert float(nut_angle(task.fastener)[0]) > -0.01
        assert abs(float(nut_advance(task.fastener)[0])) < 5e-4
    finally:
        env.close()
