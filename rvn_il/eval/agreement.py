"""Open-loop check of a trained policy: does it pick the expert's action on expert frames?

    python -m rvn_il.eval.agreement CHECKPOINT_DIR DATASET_ROOT [--split test] [--max-trajectories 40]
        [--waypoint-index -1|none] [--num-samples 1] [--aggregate first|vote] [--json out.json]

Replays expert trajectories written by ``rvn-gen`` (GNM frames + the ``rvn_meta.json``
sidecar: actions and goal). At every frame the policy sees the frame (its context grows as
in an episode) and the trajectory's goal relative to the recorded pose, exactly as
``rvn-eval`` feeds it, and its action is compared with the expert's. Printed: agreement,
recall per action, the confusion matrix, and the *adapter ceiling*: the agreement of the
same waypoint → action rule fed the ground-truth future poses (the best a perfect
trajectory predictor could reach with these policy settings), and the *blind* baseline: the
agreement of the goal follower (``rvn_data.benchmark.policies.GoalFollowerPolicy``: steer straight at
the point goal, no image), with the policy's agreement on the frames where the blind rule is
wrong: the frames where only the image tells the expert's action (a wall, a detour), and on
the first ``context_size`` decisions of each trajectory, whose context the policy pads with
the first frame (an episode's first decisions, where the expert mostly turns in place; GNM's
sampling never trains them unless ``rvn-train data.pad_context=true``).

Closed-loop success needs far more than this (errors compound), but it is minutes cheaper
than ``rvn-eval``, and a policy that disagrees with the expert on its own data is not yet
worth evaluating: use it to choose learning rates, steps and adapter settings.
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

from rvn_data.atomic import write_text_atomic
from rvn_data.conventions import Action, from_planar, relative_goal, to_local
from rvn_data.benchmark.policies import GoalFollowerPolicy
from rvn_data.dataset.reader import list_trajectories, load_traj_data, read_meta, read_rgb, rvn_trajectories
from rvn_il.policies.control import waypoints_to_action

NAMES = [a.name for a in Action]


def expert_trajectories(root: Path, split: str | None, limit: int | None) -> list[Path]:
    """rvn-gen's expert trajectory folders of ``split`` (data_splits/<name>/<split>/traj_names.txt)
    or of the whole folder (``split`` None), evenly thinned to at most ``limit``."""
    if split:
        if not any(root.glob(f"data_splits/*/{split}/traj_names.txt")):
            raise ValueError(f"{root} has no data_splits/*/{split}/traj_names.txt; pass --split all or another split")
        names = list_trajectories(root, split)[1]
    else:
        names = rvn_trajectories(root)
    dirs = [root / n for n in names if (root / n / "rvn_meta.json").is_file()]
    dirs = [d for d in dirs if read_meta(d).get("kind") == "expert"]
    if not dirs:
        raise ValueError(f"no expert trajectory with an rvn_meta.json sidecar in {root}; pass a dataset written by rvn-gen")
    if limit and len(dirs) > limit:
        dirs = [dirs[i] for i in np.linspace(0, len(dirs) - 1, limit).round().astype(int)]
    return dirs


def agreement(policy, dirs: list[Path], len_traj_pred: int, first_steps: int = 0) -> dict:
    """Confusion matrices [expert, chosen] of the policy, of the adapter ceiling, of the blind goal
    follower, of the policy on the frames where the blind goal follower is wrong, and of the
    policy on the first ``first_steps`` frames of each trajectory."""
    conf, ceiling, blind, needs_image, start = (np.zeros((4, 4), np.int64) for _ in range(5))
    follower = GoalFollowerPolicy(stop_radius=policy.control.stop_radius,
                                  theta_step_deg=np.degrees(policy.control.theta_step))
    for d in dirs:
        meta = read_meta(d)
        pos, yaw = load_traj_data(d)
        goal = np.asarray(meta["goal"], np.float64)
        policy.reset()
        for t, expert in enumerate(meta["actions"][:len(pos)]):
            pointgoal = relative_goal(from_planar(pos[t]), float(yaw[t]), goal)
            chosen = int(policy.act({"rgb": read_rgb(d / f"{t}.jpg"), "pointgoal": pointgoal}))
            conf[expert, chosen] += 1
            if t < first_steps:
                start[expert, chosen] += 1
            blind_action = follower.act({"pointgoal": pointgoal})
            blind[expert, blind_action] += 1
            if blind_action != expert:
                needs_image[expert, chosen] += 1
            future = pos[np.minimum(np.arange(t + 1, t + 1 + len_traj_pred), len(pos) - 1)]
            ideal = waypoints_to_action(to_local(future, pos[t], yaw[t]), pointgoal, policy.control)
            ceiling[expert, int(ideal)] += 1
    return {"confusion": conf, "ceiling": ceiling, "blind": blind, "needs_image": needs_image, "start": start}


def summary(conf: np.ndarray) -> dict:
    total = int(conf.sum())
    recall = {NAMES[a]: round(float(conf[a, a] / conf[a].sum()), 4) for a in range(4) if conf[a].sum()}
    return {"steps": total, "agreement": round(float(np.trace(conf) / max(total, 1)), 4), "recall": recall}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m rvn_il.eval.agreement", description=__doc__.split("\n\n")[0])
    ap.add_argument("checkpoint", help="rvn-train out_dir")
    ap.add_argument("dataset", help="expert GNM dataset written by rvn-gen (e.g. on val scenes)")
    ap.add_argument("--split", default="all", help="data_splits split to replay (train|test), or all (default)")
    ap.add_argument("--max-trajectories", type=int, default=40)
    ap.add_argument("--waypoint-index", default=None, help="policy lookahead override: an index, or none (first "
                    "waypoint beyond lookahead_min_dist); default: the checkpoint's")
    ap.add_argument("--num-samples", type=int, default=1, help="samples per decision (NoMaD)")
    ap.add_argument("--aggregate", default=None, help="NoMaD-PointGoal: first (follow sample 0) | vote (the action most "
                    "samples lead to); default: the checkpoint's")
    ap.add_argument("--json", default=None, help="also write the figures to this JSON file")
    args = ap.parse_args(argv)
    try:
        import torch

        from rvn_il.policies import load_policy

        torch.set_num_threads(max(1, torch.get_num_threads()))
        overrides = {"num_samples": args.num_samples}
        if args.aggregate is not None:
            overrides["aggregate"] = args.aggregate
        if args.waypoint_index is not None:
            overrides["waypoint_index"] = None if args.waypoint_index.lower() in ("none", "null") else int(args.waypoint_index)
        policy = load_policy(args.checkpoint, **overrides)
        dirs = expert_trajectories(Path(args.dataset), None if args.split == "all" else args.split, args.max_trajectories)
        model = policy.members[0].model
        result = agreement(policy, dirs, int(model.len_traj_pred), int(model.context_size))
    except (ValueError, OSError) as e:
        print(f"agreement: error: {e}", file=sys.stderr)
        return 2
    out = {"checkpoint": str(args.checkpoint), "dataset": str(args.dataset), "trajectories": len(dirs),
           "policy": summary(result["confusion"]), "adapter_ceiling": summary(result["ceiling"]),
           "blind_goal_follower": summary(result["blind"]), "policy_where_blind_is_wrong": summary(result["needs_image"]),
           "policy_first_decisions": summary(result["start"]),
           "confusion": result["confusion"].tolist()}
    p, c = out["policy"], out["adapter_ceiling"]
    print(f"{args.checkpoint}: {len(dirs)} expert trajectories, {p['steps']} steps")
    print(f"  agreement with the expert's action: {p['agreement']:.3f}   (adapter ceiling {c['agreement']:.3f})")
    b, n = out["blind_goal_follower"], out["policy_where_blind_is_wrong"]
    print(f"  blind goal follower: {b['agreement']:.3f}; on the {n['steps']} steps where it is wrong (the image must "
          f"tell), the policy agrees on {n['agreement']:.3f}\n    there, recall  " +
          "  ".join(f"{k} {v:.2f}" for k, v in n["recall"].items()))
    print("  recall  " + "  ".join(f"{k} {v:.2f}" for k, v in p["recall"].items()))
    f = out["policy_first_decisions"]
    print(f"  first {model.context_size} decisions of each trajectory (context padded with the first frame): "
          f"agreement {f['agreement']:.3f} on {f['steps']} steps")
    print("  confusion (rows expert, columns policy: " + " ".join(NAMES) + ")")
    for a in range(4):
        print(f"    {NAMES[a]:<13}" + " ".join(f"{v:6d}" for v in result["confusion"][a]))
    if args.json:
        write_text_atomic(Path(args.json), json.dumps(out, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
