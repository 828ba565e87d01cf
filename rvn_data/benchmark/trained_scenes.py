"""Evaluated scenes that a model's training data holds: rvn-eval compares the scenes it evaluates with those of the
datasets a checkpoint trained on, so a row measured on its own training scenes (a model trained on `rvn-gen split=val`
data, say) is said and reported, not mistaken for a held-out figure.

A policy names its training data as ``policy.training_data``: the dataset folders its networks trained on (rvn-train's
checkpoints record them in stats.json, `rvn_il.policies.loader`); a policy without it (rvn-rl's, hand-written ones) is
not checked. rvn-gen's ``manifest.json`` in each folder lists its scenes by name (`rvn_data.dataset.naming.scene_slug`,
the file stem of a mesh) with their GNM split; the scenes of the ``train`` split are the ones trained on. A folder
without a manifest (another machine's path, a dataset not made by rvn-gen) is left out and named as unchecked. Scenes
are matched by name, so two meshes with one file stem in different folders match too: the note says so."""
from __future__ import annotations

import json
from collections.abc import Iterable, Sequence
from pathlib import Path

from rvn_data.dataset.naming import scene_slug


def dataset_scenes(root: str | Path) -> dict[str, str] | None:
    """{scene name: scene spec} of the GNM train split of rvn-gen's dataset at ``root``; None without a readable
    manifest.json there."""
    try:
        manifest = json.loads((Path(root).expanduser() / "manifest.json").read_text())
        per_scene = manifest["per_scene"]
        return {str(slug): str(rec.get("scene", slug)) for slug, rec in per_scene.items()
                if rec.get("gnm_split", "train") == "train"}
    except (OSError, ValueError, KeyError, TypeError, AttributeError):
        return None


def trained_scenes_evaluated(training_data: Iterable[str] | None, specs: Sequence[str]) -> dict | None:
    """What metrics.json records when evaluated scenes ``specs`` are among the training data's: ``{"datasets": the
    folders holding them, "scenes": their names, "evaluated": len(specs), "unchecked": folders without a manifest}``;
    None when none is (or the policy names no training data)."""
    if not training_data:
        return None
    wanted = {scene_slug(s) for s in specs}
    found: dict[str, list[str]] = {}
    unchecked = []
    for root in dict.fromkeys(str(r) for r in training_data):
        scenes = dataset_scenes(root)
        if scenes is None:
            unchecked.append(root)
            continue
        for slug in sorted(wanted & set(scenes)):
            found.setdefault(slug, []).append(root)
    if not found:
        return None
    out = {"datasets": sorted({r for roots in found.values() for r in roots}), "scenes": sorted(found),
           "evaluated": len(wanted)}
    if unchecked:
        out["unchecked"] = unchecked
    return out


def trained_scenes_note(method: str, record: dict) -> str:
    """rvn-eval's note on ``record`` (`trained_scenes_evaluated`)."""
    names = record["scenes"]
    shown = ", ".join(names[:5]) + (f" and {len(names) - 5} more" if len(names) > 5 else "")
    return (f"policy {method!r} trained on {len(names)} of the {record['evaluated']} evaluated scenes ({shown}; "
            f"matched by name in the GNM train split of {', '.join(record['datasets'])}): this row is not a "
            "held-out figure; evaluate on another split, or train on data of other scenes")
