"""``rvn-eval``: closed-loop benchmark of a policy on a split's episode set (the
paper's protocol: sequential point goals, SR_1, E(G), CPK). Hydra config ``conf/eval.yaml``; e.g.

    rvn-eval policy=oracle split=val episodes.num_scenes=5 episodes.per_scene=4 workers=2
    rvn-eval policy=checkpoint policy.checkpoint_path=runs/train/nomad method=NoMaD-PointGoal

Writes ``out_dir/metrics.json``, ``out_dir/episodes.jsonl`` and ``out_dir/table.md``;
an interrupted run resumes where it stopped (``resume=false`` starts over). The default
out_dir, ``runs/eval/<split>/<method>``, takes the method label, else the checkpoint folder's
name, else the policy's. Every path and setting (scenes, the policy and its checkpoint, the
out_dir, a finished run there with other settings) is checked before any episode is generated:
bad input exits with status 2 and one line, writing nothing; a failed run exits with status 1.
"""
from __future__ import annotations

import json
import sys
from pathlib import Path

import hydra
from omegaconf import DictConfig, OmegaConf
from omegaconf.errors import OmegaConfBaseException

from rvn_data.benchmark.results import RunDir, record_key, run_identity
from rvn_data.benchmark.runner import env_kwargs, make_policy, policy_name, prepare_episodes, run_episodes
from rvn_data.benchmark.table import render_table
from rvn_data.config import CONF_DIR, register_configs
from rvn_data.embodiment import check_embodiment, describe, embodiment_of
from rvn_data.cli.common import ConfigError, check_writable_dir, entered_task, fail, record_run, run_hydra, validating

register_configs()


def evaluate(cfg: dict, on_checked=None) -> dict:
    """Run the benchmark described by a resolved config dict; returns metrics.json's content.
    Settings, scenes, policy and out_dir are checked first (`ConfigError`; nothing written but
    the run's own run.json); then ``on_checked()`` runs and the episodes are generated and run."""
    from tqdm import tqdm

    from rvn_data.benchmark.episodes_source import EnvConfig, eval_schedule
    from rvn_data.benchmark.metrics import compute_metrics

    with validating():
        env_cfg = EnvConfig.from_kwargs(**env_kwargs(cfg))
        slots = env_cfg.scene_slots("episodes.first_scene")
        keys = [(slots[pos][1], e) for pos, e in eval_schedule(slots, env_cfg.per_scene)]
        policy = make_policy(cfg["policy"], None, policy_name(cfg))  # a checkpoint that does not load fails here
        diffs = check_embodiment(getattr(policy, "embodiment", None), embodiment_of(env_cfg.agent, env_cfg.camera),
                                 _policy_what(cfg), str(cfg.get("embodiment_mismatch", "error")))
        check_writable_dir(cfg["out_dir"])
        run = RunDir(cfg["out_dir"], run_identity(cfg), {"embodiment_mismatch": diffs})
        done = run.open(resume=bool(cfg.get("resume", True)))
    if diffs:
        print(f"rvn-eval: note: policy {cfg['method']!r} was trained for another robot or camera: {describe(diffs)} "
              "(embodiment_mismatch=allow; recorded in run.json and metrics.json)", file=sys.stderr)
    if on_checked is not None:
        on_checked()
    todo = [k for k, key in enumerate(keys) if key not in done]
    workers = max(1, int(cfg.get("workers", 1)))
    show = bool(cfg.get("progress", True))
    need = sorted({keys[k][0] for k in todo})
    need_slots = [s for s in slots if s[1] in need]
    with tqdm(total=len(need_slots), desc="episodes", unit="scene", disable=not show or not need_slots) as bar:
        prepare_episodes(cfg, need_slots, workers, bar.update)
    env_cfg.store().write_index()
    with tqdm(total=len(keys), initial=len(keys) - len(todo), desc=f"eval {cfg['method']} {cfg['split']}",
              unit="ep", disable=not show) as bar:
        for _, rec in run_episodes(cfg, todo, workers):
            run.append(rec)
            done[record_key(rec)] = rec
            bar.update(1)
    records = [done[key] for key in keys]
    metrics = compute_metrics(records)
    metrics.update(split=cfg["split"], policy=cfg["policy_name"], method=cfg["method"],
                   scenes=len(slots), per_scene=env_cfg.per_scene, n_goals=env_cfg.episodes.n_goals)
    if diffs:
        metrics["embodiment_mismatch"] = diffs
    run.finish(records, metrics, render_table([metrics]))
    return metrics


def _policy_what(cfg: dict) -> str:
    ckpt = dict(cfg["policy"]).get("checkpoint_path") if isinstance(cfg["policy"], dict) else None
    return f"policy.checkpoint_path={ckpt}" if ckpt else f"policy {cfg['method']!r}"


def _plain_config(cfg: DictConfig) -> dict:
    from hydra.core.hydra_config import HydraConfig

    choice = "policy"
    if HydraConfig.initialized():
        choice = HydraConfig.get().runtime.choices.get("policy") or "policy"
    out = OmegaConf.to_container(cfg, resolve=True, throw_on_missing=True)
    out["policy_name"] = choice
    ckpt = (out.get("policy") or {}).get("checkpoint_path") if isinstance(out.get("policy"), dict) else None
    # the row label: method=, else the checkpoint folder's name (two models never share the label "checkpoint")
    out["method"] = out.get("method") or (Path(str(ckpt)).expanduser().resolve().name if ckpt else None) or choice
    return out


@hydra.main(config_path=CONF_DIR, config_name="eval", version_base="1.3")
def _main(cfg: DictConfig) -> None:
    entered_task()
    try:
        plain = _plain_config(cfg)
    except OmegaConfBaseException as err:  # e.g. policy.checkpoint_path=??? not given
        msg = (str(err).splitlines() or [type(err).__name__])[0]
        if getattr(err, "full_key", None):
            msg = f"{msg} (config key {err.full_key}: set it on the command line, e.g. {err.full_key}=...)"
        fail("rvn-eval", ConfigError(msg))
    try:
        metrics = evaluate(plain, lambda: record_run(cfg, Path(plain["out_dir"]), "rvn-eval"))
    except (ValueError, TypeError, OSError) as err:  # SceneError is a ValueError; ConfigError: status 2
        fail("rvn-eval", err)
    keys = ("SR_1", "E_G", "CPK", "SPL_1", "episodes")
    print(json.dumps({"method": plain["method"], "split": plain["split"], **{k: metrics[k] for k in keys}}))
    print(f"wrote {Path(plain['out_dir']) / 'metrics.json'}")


def main() -> None:
    run_hydra(_main, "rvn-eval", "eval")


if __name__ == "__main__":
    main()
