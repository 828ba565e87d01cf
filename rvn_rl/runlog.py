"""Training records of an rvn-rl run: episode statistics per update (summed over ranks),
TensorBoard scalars, ``metrics.jsonl``, the learning-curve PNG and the final summary."""
from __future__ import annotations

import json
from collections import deque
from pathlib import Path

import torch

from rvn_data.atomic import atomic_path, write_text_atomic
from rvn_data.benchmark.measures import episode_success

from .distrib import all_sum

FIELDS = ("episodes", "return", "success", "goals", "collisions", "distance_km", "cost")


def episode_sums(episodes: list[dict]) -> torch.Tensor:
    """Sums over finished episodes' records, all-reduced over ranks when distributed."""
    s = torch.zeros(len(FIELDS), dtype=torch.float64)
    for ep in episodes:
        s += torch.tensor([1.0, ep["return"], float(episode_success(ep)), ep["goals_reached"],
                           ep["collisions"], ep["path_length"] / 1000.0, ep["cost"]], dtype=torch.float64)
    return all_sum(s)


class RunLog:
    """Rank 0's log: a window of the last ``window`` updates' episode sums. A run that starts at ``env_steps`` (resumed
    from the checkpoint of those steps, or 0) drops what an earlier run of the out_dir logged after them (its rows
    written before it stopped, past its last checkpoint): metrics.jsonl rewritten without those rows, and TensorBoard
    told to purge the steps after ``env_steps``, so that the steps logged again appear once, in order."""

    def __init__(self, out_dir: Path, enabled: bool, window: int = 20, env_steps: int = 0):
        self.out_dir, self.enabled = out_dir, enabled
        self.window: deque = deque(maxlen=window)
        self.writer = None
        if enabled:
            from torch.utils.tensorboard import SummaryWriter
            path = out_dir / "metrics.jsonl"
            if path.is_file():
                lines = [line for line in path.read_text().splitlines() if line.strip()]
                kept = [line for line in lines if json.loads(line).get("env_steps", 0) <= env_steps]
                if len(kept) < len(lines):
                    write_text_atomic(path, "".join(line + "\n" for line in kept))
            tb = out_dir / "tb"  # an earlier run's events: those past env_steps purged (the row at env_steps stays)
            self.writer = SummaryWriter(str(tb), purge_step=env_steps + 1 if tb.is_dir() else None)

    def stats(self) -> dict:
        if not self.window:
            return {}
        s = torch.stack(list(self.window)).sum(0)
        n = float(s[0])
        if n == 0:
            return {}
        km = float(s[5])
        return {"episodes": int(n), "reward": float(s[1]) / n, "success": float(s[2]) / n, "goals": float(s[3]) / n,
                "collisions_per_km": float(s[4]) / km if km > 0 else float("nan"), "ep_cost": float(s[6]) / n}

    def record(self, env_steps: int, sums: torch.Tensor, scalars: dict) -> dict:
        self.window.append(sums)
        row = {"env_steps": int(env_steps), **self.stats(), **scalars}
        if self.enabled:
            for k, v in row.items():
                if k != "env_steps" and isinstance(v, (int, float)):
                    self.writer.add_scalar(f"train/{k}", v, env_steps)
            with open(self.out_dir / "metrics.jsonl", "a") as f:
                f.write(json.dumps(row) + "\n")
        return row

    def close(self) -> None:
        if self.writer is not None:
            self.writer.close()


def read_rows(out_dir: Path) -> list[dict]:
    path = out_dir / "metrics.jsonl"
    if not path.is_file():
        return []
    return [json.loads(line) for line in path.read_text().splitlines() if line.strip()]


def plot_learning_curve(out_dir: Path, title: str) -> Path | None:
    """``learning_curve.png``: episode return, goals per episode, collisions/km, (PPO-Lag) lambda and the
    policy's entropy; a run in which no episode has ended yet still gets its entropy curve."""
    rows = [r for r in read_rows(out_dir) if "env_steps" in r]
    if not rows:
        return None
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    keys = [k for k in ("reward", "goals", "collisions_per_km", "lambda", "ep_cost", "entropy") if any(k in r for r in rows)]
    fig, axes = plt.subplots(1, len(keys), figsize=(3.6 * len(keys), 3.2))
    for ax, key in zip(list(axes) if len(keys) > 1 else [axes], keys):
        pts = [(r["env_steps"], r[key]) for r in rows if key in r]
        ax.plot([p[0] for p in pts], [p[1] for p in pts])
        ax.set_xlabel("env steps")
        ax.set_title(key)
        ax.grid(alpha=0.3)
    fig.suptitle(title)
    fig.tight_layout()
    path = out_dir / "learning_curve.png"
    with atomic_path(path) as tmp:
        fig.savefig(tmp, format="png", dpi=100)
    plt.close(fig)
    return path


def summary(out_dir: Path, cfg, env_steps: int, seconds: float, params: int) -> str:
    """The run's closing lines; ``cfg`` is its `rvn_rl.config.RLConfig`."""
    rows = [r for r in read_rows(out_dir) if "reward" in r]
    first, last = (rows[0], rows[-1]) if rows else ({}, {})

    def fmt(key):
        a, b = first.get(key), last.get(key)
        return "-" if a is None else f"{a:.3f} -> {b:.3f}"

    rate = env_steps / max(seconds, 1e-9)
    rate = f"{rate:.0f}" if rate >= 10 else f"{rate:.2g}"  # a tiny run's rate is not 0
    lines = [f"rvn-rl {cfg.algo.name}: {env_steps} env steps in {seconds / 60:.1f} min "
             f"({rate} steps/s), {params / 1e6:.2f}M parameters "
             f"({cfg.model.backbone}, {cfg.env.size}px, {cfg.env.num_envs} envs/process)",
             f"  episode return     {fmt('reward')}", f"  goals per episode  {fmt('goals')}",
             f"  all goals reached  {fmt('success')}", f"  collisions per km  {fmt('collisions_per_km')}"]
    if "lambda" in last:
        lines += [f"  lambda             {fmt('lambda')}", f"  J_c (episode cost) {fmt('ep_cost')}"]
    lines.append(f"  out_dir {out_dir} (config.yaml, checkpoints/, metrics.jsonl, tb/, learning_curve.png)")
    return "\n".join(lines)
