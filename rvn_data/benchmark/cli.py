"""``rvn-eval``: closed-loop benchmark of a policy on a split's episode set (the
paper's protocol: sequential point goals, SR_1, E(G), CPK). Hydra config ``conf/eval.yaml``; e.g.

    rvn-eval policy=oracle split=val episodes.num_scenes=5 episodes.per_scene=4 workers=2
    rvn-eval policy=checkpoint policy.checkpoint_path=runs/train/nomad method=NoMaD-PointGoal

Writes ``out_dir/metrics.json``, ``out_dir/episodes.jsonl`` and ``out_dir/table.md``;
an interrupted run resumes where it stopped (``resume=false`` starts over). The default
out_dir, ``runs/eval/<split>/<method>``, takes the method label, else the checkpoint folder's
name, else the policy's (+ ``_first_scene<N>`` for a shard that starts at scene N > 0). Every path and setting (scenes, the policy and its checkpoint, the
out_dir, a finished run there with other settings) is checked before any episode is generated:
bad input exits with status 2 and one line, writing nothing; a failed run exits with status 1.
"""
from __future__ import annotations

import json
import sys
from dataclasses import replace
from pathlib import Path

import hydra
from omegaconf import DictConfig

from rvn_data.benchmark.policy_registry import registered_name, unregistered_note
from rvn_data.benchmark.results import RunDir, record_key, run_identity
from rvn_data.benchmark.runner import EvalJob, make_policy, prepare_episodes, run_episodes
from rvn_data.benchmark.table import render_table
from rvn_data.benchmark.traces import prune_traces, trace_file, write_trace
from rvn_data.benchmark.trained_scenes import trained_scenes_evaluated, trained_scenes_note
from rvn_data.cache_root import cache_root, keep_compiled_kernels
from rvn_data.config import CONF_DIR, checkpoint_label, register_configs, typed
from rvn_data.config_schemas import EvalConfig
from rvn_data.embodiment import check_embodiment, describe, embodiment_of
from rvn_data.scenes.sets import shared_splits, shared_splits_note
from rvn_data.cli.common import check_writable_dir, fail, record_run, validating
from rvn_data.cli.hydra_app import entered_task, run_hydra

register_configs()


def evaluate(config: EvalConfig, choice: str = "policy", on_checked=None) -> dict:
    """Run the benchmark of rvn-eval's typed config (``choice``: the policy config's name, conf/policy/<choice>.yaml;
    ``config.method`` the row label); returns metrics.json's content. Settings, scenes, policy and out_dir are checked
    first (`ConfigError`; nothing written but the run's own run.json); then ``on_checked()`` runs and the episodes
    are generated and run."""
    from tqdm import tqdm

    from rvn_data.benchmark.episodes_source import eval_schedule
    from rvn_data.benchmark.metrics import compute_metrics

    with validating():
        env_cfg = config.env_config()
        slots = env_cfg.scene_slots("episodes.first_scene")
        keys = [(slots[pos][1], e) for pos, e in eval_schedule(slots, env_cfg.per_scene)]
        job = EvalJob(env_cfg, config.policy, config.method, config.seed, config.paths)
        policy = make_policy(job.policy, None, job.name)  # a checkpoint that does not load fails here
        diffs = check_embodiment(getattr(policy, "embodiment", None), embodiment_of(env_cfg.agent, env_cfg.camera),
                                 _policy_what(config), config.embodiment_mismatch)
        check_writable_dir(config.out_dir)
        run = RunDir(config.out_dir, run_identity(config.record(), getattr(policy, "loaded_files", None)),
                     {"embodiment_mismatch": diffs})
        done = run.open(resume=config.resume)
    keep_compiled_kernels(cache_root(config.cache_dir, config.out_dir))  # after the checks: torch makes the folder
    prune_traces(config.out_dir, done)  # a run started over: the traces and maps of the one before go
    target = dict(config.policy).get("_target_")  # make_policy built it: a registered policy, else its dotted path
    if registered_name(str(target)) is None:  # a policy of one's own, imported by its dotted path
        print(f"rvn-eval: note: {unregistered_note(target)}", file=sys.stderr)
    if diffs:
        print(f"rvn-eval: note: policy {config.method!r} was trained for another robot or camera: {describe(diffs)} "
              "(embodiment_mismatch=allow; recorded in run.json and metrics.json)", file=sys.stderr)
    shared = shared_splits(config.scenes.source, config.split, config.scenes.root)
    if shared:
        print(f"rvn-eval: note: {shared_splits_note(config.scenes.root, config.split, shared)} (recorded in "
              "metrics.json)", file=sys.stderr)
    trained = trained_scenes_evaluated(getattr(policy, "training_data", None), [spec for spec, _ in slots],
                                       getattr(policy, "training_scenes", None))
    if trained:
        print(f"rvn-eval: note: {trained_scenes_note(config.method, trained)} (recorded in metrics.json)", file=sys.stderr)
    if on_checked is not None:
        on_checked()
    todo = [k for k, key in enumerate(keys) if key not in done]
    need = sorted({keys[k][0] for k in todo})
    need_slots = [s for s in slots if s[1] in need]
    with tqdm(total=len(need_slots), desc="episodes", unit="scene", disable=not config.progress or not need_slots) as bar:
        prepare_episodes(env_cfg, need_slots, config.workers, bar.update)
    env_cfg.store().write_index()
    with tqdm(total=len(keys), initial=len(keys) - len(todo), desc=f"eval {config.method} {config.split}",
              unit="ep", disable=not config.progress) as bar:
        for _, rec in run_episodes(job, todo, config.workers, policy):
            trace = rec.pop("trace", None)
            if trace is not None:  # before the record: a record in episodes.jsonl implies its trace
                write_trace(config.out_dir, rec, trace)
            run.append(rec)
            done[record_key(rec)] = rec
            bar.update(1)
    records = [done[key] for key in keys]
    metrics = compute_metrics(records)
    metrics.update(split=config.split, policy=choice, method=config.method,
                   scenes=len(slots), per_scene=env_cfg.per_scene, n_goals=env_cfg.episodes.n_goals)
    if diffs:
        metrics["embodiment_mismatch"] = diffs
    if shared:  # the report warns: a model may have trained on these scenes
        metrics["shared_scenes"] = {"folder": str(Path(config.scenes.root).expanduser()), "splits": shared}
    if trained:  # the report warns: the model trained on these scenes
        metrics["trained_scenes"] = trained
    run.finish(records, metrics, render_table([metrics]))
    if config.paths:
        from rvn_data.benchmark.trace_maps import draw_maps  # cv2 and the occupancy grid's chain: at the end, when drawn

        maps = draw_maps(config.out_dir, env_cfg.scenes, env_cfg.navmesh, env_cfg.cache_folder())
        traced = sum(trace_file(config.out_dir, *key).is_file() for key in keys)
        missing = f" ({len(keys) - traced} of {len(keys)} episodes ran without paths=true: not drawn)" \
            if traced < len(keys) else ""
        print(f"rvn-eval: {len(maps)} map(s) of the episodes' paths in {Path(config.out_dir) / 'maps'}{missing} "
              f"(clips of collisions: python -m rvn_data.benchmark.trace_maps {config.out_dir} --clips 10)",
              file=sys.stderr)
    return metrics


def _policy_what(config: EvalConfig) -> str:
    ckpt = config.policy.get("checkpoint_path") if isinstance(config.policy, dict) else None
    return f"policy.checkpoint_path={ckpt}" if ckpt else f"policy {config.method!r}"


def _typed_config(cfg: DictConfig) -> tuple[EvalConfig, str]:
    """rvn-eval's typed config (the one conversion) with the row label resolved: method=, else the checkpoint
    folder's name (two models never share the label "checkpoint"), else the policy config's name; and that name."""
    from hydra.core.hydra_config import HydraConfig

    choice = "policy"
    if HydraConfig.initialized():
        choice = HydraConfig.get().runtime.choices.get("policy") or "policy"
    config = typed(EvalConfig, cfg)
    pol = config.policy if isinstance(config.policy, dict) else {}
    method = config.method or checkpoint_label(pol.get("checkpoint_path"), pol.get("step"), pol.get("env_steps"),
                                               resolve=True) or choice
    return replace(config, method=method), choice


@hydra.main(config_path=CONF_DIR, config_name="eval", version_base="1.3")
def _main(cfg: DictConfig) -> None:
    from rvn_data.warning_lines import said_once

    entered_task()
    try:
        with validating():  # e.g. policy.checkpoint_path=??? not given: one line naming the key
            config, choice = _typed_config(cfg)
        with said_once("rvn-eval"):  # a scene's warnings in one line, once for the run and its workers
            metrics = evaluate(config, choice, lambda: record_run(cfg, Path(config.out_dir), "rvn-eval"))
    except (ValueError, TypeError, OSError) as err:  # SceneError is a ValueError; ConfigError: status 2
        fail("rvn-eval", err)
    keys = ("SR_1", "E_G", "CPK", "SPL_1", "episodes")
    print(json.dumps({"method": config.method, "split": config.split, **{k: metrics[k] for k in keys}}))
    print(f"wrote {Path(config.out_dir) / 'metrics.json'}")


def main() -> None:
    run_hydra(_main, "rvn-eval", "eval")


if __name__ == "__main__":
    main()
