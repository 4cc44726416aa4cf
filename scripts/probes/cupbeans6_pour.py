"""cupbeans6 probe (session 19): the second half of CupBeansHands' sweep-and-catch, without the ledge.
The bin is moved out of reach, the right hand rolled palm-up (tilted 10 deg) where the catch leaves it, ~25
beans dropped on its palm; the left starts from the sweep's end (blade pose 10 cm over the ledge). Then the
module's phases: the left takes the cup and brings it to the pour point, the right tips the beans in.
Run: PYTHONPATH=$PWD python scripts/probes/cupbeans6_pour.py [seeds...] [CONCURRENT=1] [N_DROP=17] [CONSTANT=expr ...]
(CONCURRENT=1: the right carries in the background while the left takes the cup, as the module notes measured it)"""
import sys
import time

import numpy as np
import torch

sys.path.insert(0, "scripts/probes")
from cupbeans6_setup import make_env  # noqa: E402

from maniladder_ms.solvers.bimanual import HandoverSolver, roll_targets, tcp_quat  # noqa: E402
from maniladder_ms.tasks import cup_beans_hands as cbh  # noqa: E402

LEDGE_TOP = 0.38
N_DROP = 25
CONCURRENT = False


def setup(s, task):
    dev, n = task.device, task.num_envs
    tray = task.tray.pose.p.clone()
    away = tray + torch.tensor([0.6, 0.0, 0.0], device=dev)
    task.tray.set_pose(cbh.Pose.create_from_pq(away))
    task.beans.set_positions(task.pile(away))
    # the right: palm-up where the catch leaves it
    catch = torch.stack([tray[:, 0] + 0.03, torch.full_like(tray[:, 0], -0.16), torch.full_like(tray[:, 0], 0.345)], 1)
    s.background = roll_targets(s, "right_arm", cbh.PALM_UP_YAW, cbh.PALM_UP_ROLL_SIGN, catch, 12, 8)
    # the left: the blade pose (palm -y, fingers down) 10 cm over the ledge, above the tray
    blade = torch.stack([tray[:, 0] - 0.02, torch.full_like(tray[:, 0], -0.03), torch.full_like(tray[:, 0], LEDGE_TOP + 0.1)], 1)
    bq = tcp_quat(torch.tensor([[0.0, -1.0, 0.0]], device=dev).expand(n, 3), torch.tensor([[1.0, 0, 0]], device=dev).expand(n, 3))
    s.set_ee("right_hand", "cup", steps=0)
    s.move({"left_arm": (blade, bq)}, max_steps=80, pos_tol=0.01)
    while s.background is not None:
        s.step()
    q = cbh.palm_up_quat(n, dev)
    s.move({"right_arm": (catch, q)}, max_steps=40, pos_tol=0.003)
    tcp = s.tcp("right_arm")
    print(f"  right at {tcp.p.numpy().round(3)}, palm normal {cbh.quaternion_to_matrix(tcp.q)[0, :, 2].numpy().round(2)}; "
          f"left at {s.tcp('left_arm').p.numpy().round(3)}")
    # drop beans over the palm: a grid in the TCP frame
    xs, ys = np.linspace(-0.04, 0.06, 5), np.linspace(0.0, 0.06, 5)
    grid = [[x, y, -0.02] for x in xs for y in ys]
    pick = np.linspace(0, len(grid) - 1, N_DROP).round().astype(int)  # spread over the palm
    local = torch.tensor([grid[i] for i in pick], dtype=torch.float32, device=dev)
    world = cbh.quaternion_apply(tcp.q.expand(len(local), 4), local) + tcp.p
    pos = task.beans.positions().clone()
    pos[:, :N_DROP] = world[None]
    task.beans.set_positions(pos)
    for _ in range(40):
        s.step()


def run(seed, env):
    t0 = time.time()
    with HandoverSolver.episode(env, seed) as s:
        task = env.unwrapped
        setup(s, task)
        palm0 = int(task.in_palm().sum())
        k0 = int(task.elapsed_steps[0])
        held = []
        step = s.step

        def watched(*a, **kw):  # after the lift: is the cup held (ee.holds) on every step
            out = step(*a, **kw)
            if float(task.cup.pose.p[0, 2]) > 0.01:
                held.append(bool(task.ee.holds(task.cup, "left")[0]))
            return out
        s.step = watched
        if CONCURRENT:  # the right carries its beans (background) while the left takes the cup
            s.background = cbh.carry_palm_to_cup(s, task)
        cbh.left_takes_cup(s, task)
        while s.background is not None:
            s.step()
        k1 = int(task.elapsed_steps[0])
        palm1 = int(task.in_palm().sum())
        cup_z = float(task.cup.pose.p[0, 2])
        touched = []
        step2 = s.step

        def watched2(*a, **kw):
            out = step2(*a, **kw)
            touched.append(bool(task.ee.touches(task.cup, "right")[0]))
            return out
        s.step = watched2
        cbh.pour_palm_into_cup(s, task, carried=CONCURRENT)
        print(f"  cup bottom z {cup_z:.3f} before the tilt; the right touched the cup on {sum(touched)} steps")
        info = s.info
        m = task.delivery_metrics()
        b = task.beans.positions()[0, :N_DROP] - task.cup.pose.p[0]
        out = b[~task.in_cup()[0, :N_DROP]]
        table = out[out[:, 2] < -0.1]
        print("  left over (from the cup, mean/std xy on the table):", len(out), len(table),
              table[:, :2].mean(0).numpy().round(3) if len(table) else None, table[:, :2].std(0).numpy().round(3) if len(table) > 1 else None)
        print(f"seed {seed}: palm {palm0} -> {palm1} (after the cup phase) -> {int(task.in_palm().sum())}; "
              f"in cup {int(m['beans_in_cup'])}, delivered {int(m['beans_delivered'])}, carried {int(m['beans_carried'])}; "
              f"cup z {float(task.cup.pose.p[0, 2]):.3f}, held {bool(info['cup_held'])}, lifted {bool(info['cup_lifted'])}, "
              f"let_go {bool(info['cup_let_go'])}, success {bool(info['success'])}; held every step since lift: "
              f"{all(held) if held else None} ({sum(held)}/{len(held)}); steps {k0}->{k1}->{int(task.elapsed_steps[0])}; "
              f"{time.time() - t0:.0f}s", flush=True)


if __name__ == "__main__":
    # arguments: seeds, and NAME=python-expression overrides of the module's constants (a variant to try)
    seeds = [int(a) for a in sys.argv[1:] if "=" not in a] or [100, 101, 102, 103, 104]
    for a in sys.argv[1:]:
        if "=" in a:
            name, expr = a.split("=", 1)
            if name in ("CONCURRENT", "N_DROP"):  # the probe's own settings
                globals()[name] = int(expr)
            else:
                setattr(cbh, name, eval(expr, {"np": np, "cbh": cbh}))
            print("override", name, "=", expr)
    env = make_env()
    for seed in seeds:
        run(seed, env)
    env.close()
