"""learning_curves.png: the training curves of the runs with train.overlap false and true (and with its lag
corrections, ppo.decoupled and ppo.recompute_advantages, where those runs are there) on one set of axes (goals per
episode, episode return, collisions per km, entropy), a 20-update moving mean over rvn-rl's metrics.jsonl rows.

    python curves.py OUT   # OUT of run_pair.sh (run_variant.sh's runs copied into OUT/train/ppo_overlap_<variant>)
"""
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.ticker import FuncFormatter  # noqa: E402
import numpy as np  # noqa: E402

from rvn_rl.runlog import read_rows  # noqa: E402

out = Path(sys.argv[1])
keys = ("goals", "reward", "collisions_per_km", "entropy")
fig, axes = plt.subplots(1, len(keys), figsize=(3.8 * len(keys), 3.2))
for arm, label in (("false", "overlap=false"), ("true", "overlap=true"), ("decoupled", "overlap, decoupled"),
                   ("recompute", "overlap, recomputed values")):
    if not (out / "train" / f"ppo_overlap_{arm}").is_dir():
        continue
    rows = [r for r in read_rows(out / "train" / f"ppo_overlap_{arm}") if "goals" in r]
    steps = np.array([r["env_steps"] for r in rows])
    for ax, key in zip(axes, keys):
        v = np.array([r[key] for r in rows], float)
        w = min(20, len(v))
        mean = np.convolve(v, np.ones(w) / w, mode="valid")
        ax.plot(steps[w - 1:], mean, label=label)
for ax, key in zip(axes, keys):
    ax.set_title(key)
    ax.set_xlabel("env steps")
    ax.xaxis.set_major_formatter(FuncFormatter(lambda v, _: f"{v / 1000:.0f}k"))
    ax.grid(alpha=0.3)
axes[0].legend()
fig.suptitle("rvn-rl PPO: train.overlap false, true, and true with a lag correction (20-update moving mean)")
fig.tight_layout()
fig.savefig(out / "learning_curves.png", dpi=100)
print(out / "learning_curves.png")
