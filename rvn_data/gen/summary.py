"""The one-screen summary printed at the end of `rvn-gen`."""
from __future__ import annotations

from collections import Counter
from pathlib import Path

from rvn_data.dataset.scene_job import TIMERS, SceneResult
from rvn_data.dataset.settings import GenSettings


def summary(s: GenSettings, out_dir: Path, results: list[SceneResult], specs: list[str], missing: list[str],
            shard_index: int, num_shards: int, seconds: float) -> str:
    """Scenes, trajectories kept/attempted, frames, time and frames/s of this run, the notes of the scenes it loaded
    (`SceneResult.notes`) and its failures."""
    lines = [f"rvn-gen: {s.kind} dataset '{s.name}' -> {out_dir}",
             f"  shard {shard_index}/{num_shards}: {len(results)} of {len(specs)} scenes; margin {s.margin} m, "
             f"paths in [{s.d_min}, {s.d_max}] m" + (f", k_pre {s.k_pre}, k_post {s.k_post}" if s.kind == "negative" else "")]
    lines.append(f"  {'scene':<28}{'kept':>9}{'attempts':>10}{'frames':>8}{'new':>6}  status")
    kept = asked = attempts = frames = new_frames = 0
    rejected = Counter()
    timing = dict.fromkeys(TIMERS, 0.0)
    renderers = set()
    shown = 0
    for r in results:
        for k in TIMERS:
            timing[k] += r.timing.get(k, 0.0)
        if r.record is None:
            if shown < 12:
                lines.append(f"  {r.slug:<28}{'-':>9}{'-':>10}{'-':>8}{'-':>6}  FAILED")
                shown += 1
            continue
        rec = r.record
        k_ = len(rec["trajectories"])
        f_ = sum(t["frames"] for t in rec["trajectories"])
        kept, asked, attempts, frames, new_frames = (kept + k_, asked + rec["trajectories_per_scene"],
                                                     attempts + rec["attempts"], frames + f_, new_frames + r.frames)
        rejected.update(rec["rejected"])
        renderers.update(rec["renderers"])
        status = "repaired" if r.redone else "ok" if r.skipped == 0 else ("resumed" if r.written else "done before")
        if shown < 12:
            ratio = f"{k_}/{rec['trajectories_per_scene']}"
            lines.append(f"  {r.slug:<28}{ratio:>9}{rec['attempts']:>10}"
                         f"{f_:>8}{r.frames:>6}  {status}")
            shown += 1
    if len(results) > shown:
        lines.append(f"  ... {len(results) - shown} more scenes")
    rej = ", ".join(f"{k} {v}" for k, v in sorted(rejected.items())) or "none"
    lines.append(f"  trajectories kept {kept}/{asked} ({s.kind}), attempts {attempts}; rejected: {rej}")
    work = sum(timing.values())
    share = ", ".join(f"{k} {100 * v / work:.0f}%" for k, v in timing.items()) if work > 0 else "nothing new"
    rate = new_frames / seconds if seconds > 0 else 0.0
    lines.append(f"  frames {frames} in the dataset, {new_frames} written now in {seconds:.1f} s "
                 f"= {rate:.0f} frames/s ({share}); renderer {', '.join(sorted(renderers)) or '-'}")
    if missing:
        lines.append(f"  splits/manifest: waiting for {len(missing)} scenes of other shards "
                     "(the last shard writes them, or run rvn-gen mode=merge)")
    else:
        maps = ", maps/*.png" if any((Path(out_dir) / "maps").glob("*.png")) else ""
        lines.append(f"  wrote data_splits/{s.name}/{{train,test}}/traj_names.txt, data_config.yaml, manifest.json{maps}")
    notes = [(r.slug, note) for r in results for note in r.notes]
    if notes:
        lines.append(f"  notes ({len(notes)}):")
        lines += [f"    {slug}: {note}" for slug, note in notes[:20]]
    failures = [r for r in results if r.error]
    if failures:
        lines.append(f"  FAILED scenes ({len(failures)}):")
        lines += [f"    {r.error}" for r in failures[:20]]
    return "\n".join(lines)
