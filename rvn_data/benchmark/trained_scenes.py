"""Evaluated scenes that a model's training data holds: rvn-eval compares the scenes it evaluates with those of the
datasets a checkpoint trained on, so a row measured on its own training scenes (a model trained on `rvn-gen split=val`
data, say) is said and reported, not mistaken for a held-out figure.

A policy names what it trained on as ``policy.training_data``, the dataset folders its networks trained on (rvn-train's
checkpoints record them in stats.json, `rvn_il.policies.loader`): rvn-gen's ``manifest.json`` in each folder lists its
scenes by name (`rvn_data.dataset.naming.scene_slug`, the file stem of a mesh) with their GNM split, and the scenes of
the ``train`` split are the ones trained on. Or as ``policy.training_scenes``, ``{"source": what says so, "scenes":
their specs, or None where they could not be listed}`` (rvn-rl's checkpoints: the train scenes of the run's
config.yaml, `rvn_rl.policy`). A policy with neither (a hand-written one) is not checked. A folder without a manifest
(another machine's path, a dataset not made by rvn-gen) or scenes that could not be listed are named as unchecked.
Scenes are matched by name, so two meshes with one file stem in different folders match too: the note says so."""
from __future__ import annotations

import json
from collections.abc import Iterable, Sequence
from pathlib import Path

from rvn_data.dataset.naming import scene_slug


def dataset_scenes(root: str | Path, gnm_split: str | None = "train") -> dict[str, str] | None:
    """{scene name: scene spec} of the GNM split ``gnm_split`` (None or ``all``: every split) of rvn-gen's dataset at
    ``root``; None without a readable manifest.json there."""
    try:
        manifest = json.loads((Path(root).expanduser() / "manifest.json").read_text())
        per_scene = manifest["per_scene"]
        return {str(slug): str(rec.get("scene", slug)) for slug, rec in per_scene.items()
                if gnm_split in (None, "all") or rec.get("gnm_split", "train") == gnm_split}
    except (OSError, ValueError, KeyError, TypeError, AttributeError):
        return None


def trained_scenes_evaluated(training_data: Iterable[str] | None, specs: Sequence[str],
                             training_scenes: dict | None = None) -> dict | None:
    """What metrics.json records when evaluated scenes ``specs`` are among those a policy trained on (its
    ``training_data`` folders, its ``training_scenes``): ``{"sources": the folders or files naming them, "scenes":
    their names, "evaluated": how many scenes were evaluated, "unchecked": sources that could not be read}``; None
    when none is (or the policy names neither)."""
    sources = [(root, dataset_scenes(root)) for root in dict.fromkeys(str(r) for r in training_data or ())]
    if training_scenes:
        listed = training_scenes.get("scenes")
        sources.append((str(training_scenes["source"]),
                        None if listed is None else {scene_slug(str(s)): str(s) for s in listed}))
    wanted = {scene_slug(s) for s in specs}
    found: dict[str, list[str]] = {}
    unchecked = []
    for source, scenes in sources:
        if scenes is None:
            unchecked.append(source)
            continue
        for slug in sorted(wanted & set(scenes)):
            found.setdefault(slug, []).append(source)
    if not found:
        return None
    out = {"sources": sorted({r for roots in found.values() for r in roots}), "scenes": sorted(found),
           "evaluated": len(wanted)}
    if unchecked:
        out["unchecked"] = unchecked
    return out


def shown_names(names: Sequence[str], first: int = 5) -> str:
    """``names`` for a note: the first ``first``, then how many more."""
    return ", ".join(names[:first]) + (f" and {len(names) - first} more" if len(names) > first else "")


def trained_scenes_note(method: str, record: dict) -> str:
    """rvn-eval's note on ``record`` (`trained_scenes_evaluated`)."""
    names = record["scenes"]
    shown = shown_names(names)
    return (f"policy {method!r} trained on {len(names)} of the {record['evaluated']} evaluated scenes ({shown}; "
            f"matched by name in what it trained on: {', '.join(record['sources'])}): this row is not a held-out "
            "figure; evaluate on another split, or train on other scenes")
