"""Agreement with the expert by decision index t (0, 1, 2, 3, >= 4) on held-out expert trajectories (run 7).

    python first_decisions.py CHECKPOINT_DIR VAL_EXPERT_ROOT

Replays up to 40 trajectories as the agreement tool does (vote of 8; the policy's context is
filled with the first frame after reset()), and prints per t: frames, agreement, the expert's and
the policy's share of MOVE_FORWARD.
"""
import sys, numpy as np, torch
from pathlib import Path
from rvn_il.policies import load_policy
from rvn_il.eval.agreement import expert_trajectories
from rvn_data.conventions import from_planar, relative_goal
from rvn_data.dataset.reader import load_traj_data, read_meta, read_rgb
torch.set_num_threads(2)
ck, root = sys.argv[1], sys.argv[2]
pol = load_policy(ck, num_samples=8, aggregate="vote")
dirs = expert_trajectories(Path(root), None, 40)
hits = {}
for d in dirs:
    meta = read_meta(d); pos, yaw = load_traj_data(d); goal = np.asarray(meta["goal"])
    pol.reset()
    for t, ex in enumerate(meta["actions"][:len(pos)]):
        pg = relative_goal(from_planar(pos[t]), float(yaw[t]), goal)
        a = int(pol.act({"rgb": read_rgb(d / f"{t}.jpg"), "pointgoal": pg}))
        b = min(t, 4)
        hits.setdefault(b, []).append((a == ex, ex, a))
for b in sorted(hits):
    h = hits[b]; print(b, len(h), round(np.mean([x[0] for x in h]), 3), 'expert fwd share', round(np.mean([x[1] == 1 for x in h]), 2), 'policy fwd share', round(np.mean([x[2] == 1 for x in h]), 2))
