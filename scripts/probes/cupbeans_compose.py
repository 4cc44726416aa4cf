"""CupBeansHands probe (session 19): the phases composed (sweep_and_catch, then carry_palm_to_cup in the background while
left_takes_cup, then pour_palm_into_cup). Run: PYTHONPATH=$PWD python scripts/probes/cupbeans_compose.py 100 101 102"""
import sys, time
sys.path.insert(0, "scripts/probes")
from cupbeans6_setup import make_env
from maniladder_ms.solvers.bimanual import HandoverSolver
from maniladder_ms.tasks import cup_beans_hands as cbh
env = make_env()
for seed in [int(a) for a in sys.argv[1:]]:
    t = time.time()
    with HandoverSolver.episode(env, seed) as s:
        task = env.unwrapped
        c = cbh.sweep_and_catch(s, task)
        s.background = cbh.carry_palm_to_cup(s, task)
        cbh.left_takes_cup(s, task)
        while s.background is not None:
            s.step()
        pre = int(task.in_palm().sum())
        cbh.pour_palm_into_cup(s, task, carried=True)
        for _ in range(20):
            s.step()
        info = s.info
        print(seed, {k: int(v[0]) for k, v in c.items()}, "palm before pour", pre, "delivered", int(info["beans_delivered"][0]),
              "success", bool(info["success"][0]), "held up", bool(info["cup_lifted"][0]), "steps", int(task.elapsed_steps[0]),
              f"{time.time()-t:.0f}s", flush=True)
