"""Run `rvn-gen` for a composed config: shard the scene list, generate, finalise, summarise.

Scenes of this shard run one after another (or on `workers` processes, one scene each at a
time); a scene done before is checked (every trajectory it recorded still whole) and what is
missing or damaged is redone, with one line saying so. A scene that fails is noted in ``.rvn/failed/<slug>.txt`` and the others go on;
the exit status is non-zero when any scene failed. See `rvn_data.dataset.finalise` for
how shards meet.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Mapping

from rvn_data.cli.common import ConfigError, validating
from rvn_data.config import typed
from rvn_data.config_schemas import GenConfig
from rvn_data.dataset import naming
from rvn_data.dataset.finalise import Finalised
from rvn_data.dataset.gnm_writer import GNMWriter
from rvn_data.dataset.remake import record_command, remake_hint
from rvn_data.dataset.scene_job import TIMERS, SceneResult, run_scene
from rvn_data.dataset.settings import GenSettings
from rvn_data.dataset.verify import summarise
from rvn_data.gen.summary import summary
from rvn_data.numba_note import note_first_compile
from rvn_data.scenes.sets import ScenesConfig, shared_splits, shared_splits_note
from rvn_data.worker_logs import spawned_pool
from rvn_data.worker_threads import settle_worker_threads


def list_scenes(scenes: ScenesConfig) -> list[str]:
    from rvn_data.scenes.sets import scene_specs

    specs = scene_specs(scenes.source, scenes.split, root=scenes.root, num_scenes=scenes.num_scenes,
                        first_scene=scenes.first_scene)
    naming.check_unique(list(specs))
    return list(specs)


GEN_WORKER_THREADS = 1  # CPU threads of each worker process (`rvn_data.worker_threads`): a node's cores are used by workers


def _scene_worker(args: tuple) -> SceneResult:
    spec, settings, out_dir, n, scene_cfg = args
    try:
        return run_scene(spec, settings, Path(out_dir), n, scene_cfg)
    except Exception as e:  # one scene's failure must not stop the others
        return SceneResult(slug=naming.scene_slug(spec), spec=spec, error=_message(spec, e))


def _message(spec: str, e: Exception) -> str:
    text = str(e).strip().splitlines()[0] if str(e).strip() else type(e).__name__
    if spec not in text and naming.scene_slug(spec) not in text:
        text = f"scene {spec}: {text}"
    return text if isinstance(e, ValueError) else f"{text} ({type(e).__name__})"


@dataclass
class GenReport:
    """Outcome of `generate`: exit status, per-scene results, wall time (s), frames written."""

    status: int
    results: list[SceneResult] = field(default_factory=list)
    seconds: float = 0.0

    @property
    def frames(self) -> int:
        return sum(r.frames for r in self.results)


def generate(cfg: GenConfig | Mapping[str, Any], overrides: list[str] | None = None) -> GenReport:
    """Generate this shard's scenes and finalise when every shard is done. ``cfg``: rvn-gen's typed
    config (`GenConfig`), or a mapping of the settings that differ from its defaults; ``overrides``
    (the command line's) are recorded in the out_dir for messages that ask to rerun it."""
    t_start = time.perf_counter()
    with validating():  # bad input: ConfigError (exit status 2), before anything is written
        config = typed(GenConfig, cfg)
        settings = GenSettings.resolve(config)
        out_dir = Path(config.out_dir).expanduser().resolve()
        specs = list_scenes(config.scenes)
        if not specs:
            sc = config.scenes
            raise ValueError(f"no scenes to generate: scenes.first_scene={sc.first_scene} and scenes.num_scenes="
                             f"{sc.num_scenes} select none of the {sc.split} split's scenes; lower first_scene or "
                             "raise num_scenes (null: every scene)")
        gnm = GNMWriter.open(out_dir, settings)
    if config.mode == "merge":
        return GenReport(merge(gnm, specs, config.allow_partial))
    if settings.kind == "expert" and settings.margin <= settings.agent.r_robot:
        print(f"warning: expert dataset.margin={settings.margin} m is not larger than r_robot={settings.agent.r_robot} m")
    if settings.kind == "negative" and settings.margin >= settings.agent.r_robot:
        print(f"warning: negative dataset.margin={settings.margin} m is not smaller than r_robot={settings.agent.r_robot} m")
    shared = shared_splits(config.scenes.source, config.scenes.split, config.scenes.root)
    if shared:
        print(f"note: {shared_splits_note(config.scenes.root, config.scenes.split, shared)}")
    if overrides is not None:
        record_command(out_dir, overrides)
    shard_index, num_shards = config.shard_index, config.num_shards
    mine = specs[shard_index::num_shards]
    jobs = [(spec, settings, str(out_dir), config.trajectories_per_scene, config.scenes) for spec in mine]
    note_first_compile("rvn-gen")
    results = _run(jobs, config.workers, config.trajectories_per_scene, config.progress)
    for r in results:
        gnm.note_failure(r.slug, r.error)
        if r.redone:
            print(redone_line(r))
    done = gnm.finalise_dataset(specs)
    seconds = time.perf_counter() - t_start
    print(summary(settings, out_dir, results, specs, done.missing, shard_index, num_shards, seconds))
    _report_finalised(done, specs, out_dir)
    return GenReport(1 if any(r.error for r in results) else 0, results, seconds)


def redone_line(r: SceneResult) -> str:
    """``rvn-gen: <slug>: 1 trajectory damaged (<name>: 7.jpg truncated), redone``."""
    n = len(r.redone)
    outcome = "redone" if r.error is None else f"not redone: {r.error}"
    return f"rvn-gen: {r.slug}: {n} {'trajectory' if n == 1 else 'trajectories'} damaged ({summarise(r.redone)}), {outcome}"


def merge(gnm: GNMWriter, specs: list[str], allow_partial: bool) -> int:
    """`mode=merge`: write splits, data_config and manifest from the scenes done so far."""
    missing = gnm.missing_scenes(specs)
    if missing and not allow_partial:  # bad input: ConfigError (exit status 2)
        raise ConfigError(f"out_dir={gnm.out_dir}: {len(missing)} of {len(specs)} scenes are not generated yet "
                         f"(first: {missing[0]}); run the missing shards, or merge with allow_partial=true")
    done = gnm.finalise_dataset(specs, allow_missing=True)
    print(f"rvn-gen merge: {gnm.out_dir}: wrote data_splits/{gnm.settings.name}/, data_config.yaml, manifest.json "
          f"({len(specs) - len(missing)} of {len(specs)} scenes)")
    _report_finalised(done, specs, gnm.out_dir)
    return 0


def _report_finalised(done: Finalised, specs: list[str], out_dir: Path) -> None:
    """Say what the splits kept from earlier runs, which scenes changed split and which stale caches were removed."""
    if done.extra:
        what = (f"of {len(done.earlier)} scenes that are not in this run's scene list (e.g. {done.earlier[0]})"
                if done.earlier else f"beyond trajectories_per_scene (e.g. {done.extra[0]})")
        print(f"  note: the splits and manifest.json keep {len(done.extra)} trajectories earlier runs wrote here {what}; "
              "manifest.json lists them under kept_from_earlier_runs; for a dataset without them use a new out_dir")
    if done.left_out:
        n, (first, problem) = len(done.left_out), next(iter(done.left_out.items()))
        them, slug = "it" if n == 1 else "them", first.rsplit("_", 2)[0]  # <slug>_<kind>_<index>
        hint = remake_hint(out_dir, them) if slug in {naming.scene_slug(spec) for spec in specs} else \
            f"rerun rvn-gen into {out_dir} with {slug}'s scene in its scene list to redo {them}"
        print(f"  note: {n} {'trajectory' if n == 1 else 'trajectories'} listed by the scene records "
              f"{'is' if n == 1 else 'are'} missing or damaged ({first}: {problem}{', ...' if n > 1 else ''}) and left "
              f"out of the splits; {hint}")
    if done.moved:
        n, (first, how) = len(done.moved), next(iter(done.moved.items()))
        print(f"  note: {n} {'scene' if n == 1 else 'scenes'} changed split ({first}: {how}{', ...' if n > 1 else ''}; "
              "manifest.json has each scene's gnm_split): the split is drawn over every scene of the dataset, so "
              "adding scenes splits it anew; a model trained on the old lists was validated on scenes now in train "
              "(or the reverse). To keep a fixed validation set, generate it as a dataset of its own "
              "(dataset.train_fraction=1.0 here, data.val_root=<it> in rvn-train)")
    if done.removed:
        print(f"  removed {len(done.removed)} stale visualnav-transformer cache(s) of the old split lists "
              f"(rebuilt on its next training): {', '.join(done.removed)}")


def _run(jobs: list[tuple], workers: int, n: int, progress: bool) -> list[SceneResult]:
    from tqdm import tqdm

    if workers < 1:
        raise ValueError(f"workers={workers} must be >= 1")
    if workers == 1 or len(jobs) <= 1:
        bar = tqdm(total=len(jobs) * n, unit="traj", disable=not progress, dynamic_ncols=True)
        out = []
        for spec, settings, out_dir, n_, scene_cfg in jobs:
            bar.set_postfix_str(naming.scene_slug(spec))
            try:
                out.append(run_scene(spec, settings, Path(out_dir), n_, scene_cfg, on_trajectory=bar.update))
            except Exception as e:
                out.append(SceneResult(slug=naming.scene_slug(spec), spec=spec, error=_message(spec, e)))
        bar.close()
        return out
    # each worker's records (each scene's renderer) in the run's console and log file
    with spawned_pool(min(workers, len(jobs)), GEN_WORKER_THREADS, settle_worker_threads,
                      (GEN_WORKER_THREADS,)) as pool:
        bar = tqdm(total=len(jobs), unit="scene", disable=not progress, dynamic_ncols=True)
        out = []
        for r in pool.imap_unordered(_scene_worker, jobs):
            out.append(r)
            bar.update(1)
        bar.close()
    return sorted(out, key=lambda r: r.slug)


__all__ = ["GenReport", "generate", "merge", "redone_line", "TIMERS"]
