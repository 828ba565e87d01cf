"""Generate the trajectories of one scene: resume, plan, render, encode, write, map, record.

Trajectory i of a scene is the first kept attempt a = 0 … max_attempts−1, each drawn
from `attempt_rng(seed, kind, slug, i, a)`; folders already on disk are skipped when whole
(`GNMWriter.check`: a scene with a record is done only when every trajectory it lists still is),
so a rerun only does what is missing, and redoes, with the same bytes, what was damaged. When trajectory i fails every attempt and no earlier
index was kept, the scene is hopeless for these settings: `SceneError` with the reason.
The scene's record (`.rvn/scenes/<slug>.json`, deterministic, no timings) is written last.
"""
from __future__ import annotations

import os
import time
import warnings
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from rvn_data.cache_root import ENV as CACHE_ENV
from rvn_data.conventions import to_planar
from rvn_data.dataset import naming, writer
from rvn_data.dataset.floors import by_floor, floor_grid, floor_heights
from rvn_data.dataset.gnm_writer import GNMWriter
from rvn_data.dataset.reader import load_traj_data
from rvn_data.dataset.settings import GenSettings
from rvn_data.dataset.topdown import render_panels
from rvn_data.dataset.trajectory import Rollout, SceneContext, attempt
from rvn_data.render.base import CALL_VIEWS
from rvn_data.scenes.scene import SceneError
from rvn_data.scenes.sets import ScenesConfig

TIMERS = ("setup", "planning", "rendering", "encoding", "writing")


@dataclass
class SceneResult:
    """What a scene job reports back (timings and counts of this run, not persisted)."""

    slug: str
    spec: str
    record: dict | None = None
    error: str | None = None
    timing: dict = field(default_factory=lambda: dict.fromkeys(TIMERS, 0.0))
    written: int = 0  # trajectories written by this run
    frames: int = 0  # frames written by this run
    skipped: int = 0  # trajectories found complete on disk
    redone: dict = field(default_factory=dict)  # name -> what was wrong with it on disk (removed, written again)
    notes: list = field(default_factory=list)  # what loading the scene warned of (`_Scene.notes`)


def _diagnose(s: GenSettings, scene_id: str, reasons: Counter, max_geodesic: float) -> str:
    reason, _ = reasons.most_common(1)[0]
    hint = {
        "no_goal": f"no goal at a geodesic distance in [d_min={s.d_min}, d_max={s.d_max}] m "
                   f"(largest distance seen {max_geodesic:.2f} m); lower dataset.d_min",
        "start_blocked": f"no start outside the inflated obstacles with dataset.margin={s.margin} m; lower dataset.margin",
        "no_path": f"no A* path between start and goal with obstacles inflated by dataset.margin={s.margin} m "
                   "(the margin closes the passages); lower dataset.margin",
        "path_length": f"every A* path is outside [d_min={s.d_min}, d_max={s.d_max}] m; widen the range",
        "collided": f"the follower collides on every expert path (dataset.margin={s.margin} m); raise dataset.margin",
        "no_collision": f"no negative attempt collides (dataset.margin={s.margin} m, max_steps={s.max_steps}); "
                        "lower dataset.margin",
        "timeout": f"the follower never finishes within dataset.max_steps={s.max_steps}; raise it",
    }[reason]
    counts = ", ".join(f"{k} {v}" for k, v in sorted(reasons.items()))
    return f"scene {scene_id}: {hint} ({counts} of {sum(reasons.values())} attempts)"


class _Scene:
    """Lazily built scene resources (nothing is loaded when every trajectory exists)."""

    def __init__(self, spec: str, settings: GenSettings, scenes: ScenesConfig, timing: dict):
        from rvn_data.navmesh.source import open_navmesh
        from rvn_data.render import make_renderer
        from rvn_data.scenes.loader import load_scene
        from rvn_data.sim import Simulator

        t0 = time.perf_counter()
        with warnings.catch_warnings(record=True) as said:  # the loader's notes (a tilted floor, a texture it
            warnings.simplefilter("always")  # cannot decode): the summary lists them, a worker's too
            self.scene = load_scene(spec, up_axis=scenes.up_axis, unit_scale=scenes.unit_scale, level=scenes.level)
        self.notes = [str(w.message) for w in said]
        navmesh = open_navmesh(self.scene, settings.navmesh, os.environ.get(CACHE_ENV) or None)  # shared builds
        self.ctx = SceneContext(navmesh=navmesh, sim=Simulator(navmesh, settings.agent), scene=self.scene,
                                settings=settings)
        self._renderer, self._timing = None, timing
        self._make_renderer = lambda: make_renderer(self.scene, settings.camera,
                                                    backend=settings.renderer, device=settings.render_device)
        timing["setup"] += time.perf_counter() - t0

    @property
    def renderer(self):
        if self._renderer is None:  # built at the first frame to render: set-up time too (~0.2 s gl at 256²)
            t0 = time.perf_counter()
            self._renderer = self._make_renderer()
            self._timing["setup"] += time.perf_counter() - t0
        return self._renderer

    def close(self) -> None:
        if self._renderer is not None:
            self._renderer.close()


def _meta(s: GenSettings, scene_id: str, spec: str, split: str, name: str, index: int, a: int,
          rejected: Counter, r: Rollout, backend: str) -> dict:
    def vec(x):
        return None if x is None else [float(v) for v in np.asarray(x).reshape(-1)]

    return {
        "name": name, "scene": scene_id, "spec": spec, "split": split, "kind": s.kind, "index": index,
        "seed": s.seed, "attempt": a, "rejected": dict(sorted(rejected.items())),
        "start": vec(r.start), "start_yaw": r.start_yaw, "goal": vec(r.goal), "goal_planar": vec(to_planar(r.goal)),
        "geodesic": r.geodesic, "path_length": r.plan.length,
        "waypoints_planar": to_planar(r.plan.waypoints).tolist(),
        "frames": len(r.yaws), "actions": r.actions, "steps": r.steps,
        "t_c": r.t_c, "t_c_episode": r.t_c_episode, "contact": vec(r.contact),
        "collision_planar": None if r.t_c is None else vec(to_planar(r.positions[r.t_c])),
        "renderer": backend, "settings": s.identity(),
    }


def run_scene(spec: str, settings: GenSettings, out_dir: Path, trajectories_per_scene: int, scenes: ScenesConfig,
              on_trajectory=None) -> SceneResult:
    """Generate (or resume) one scene's trajectories and its map and record."""
    s, gnm = settings, GNMWriter(out_dir, settings)  # opened (checked) by the parent
    slug = naming.scene_slug(spec)
    res = SceneResult(slug=slug, spec=spec)
    rec = gnm.scene_record(slug)
    recorded = {t["name"]: t["frames"] for t in rec["trajectories"]} if rec is not None else {}
    checked = {}  # name -> (what is wrong or None, sidecar) of the folders checked
    if rec is not None and rec.get("trajectories_per_scene") == trajectories_per_scene:
        checked = {name: gnm.check(name, frames) for name, frames in recorded.items()}
        if not any(problem for problem, _ in checked.values()):  # done, and every folder still whole
            res.record, res.skipped = rec, len(rec["trajectories"])
            if on_trajectory:
                on_trajectory(trajectories_per_scene)
            return res
    split = scenes.split
    scene = None
    kept, failed, reasons = [], [], Counter()
    try:
        for index in range(trajectories_per_scene):
            name = naming.traj_name(slug, s.kind, index)
            problem, meta = checked[name] if name in checked else gnm.check(name, recorded.get(name))
            if meta is not None:
                reasons.update(meta["rejected"])
                res.skipped += 1
            else:
                if problem is not None:
                    gnm.discard(name)
                    res.redone[name] = problem
                if scene is None:
                    scene = _Scene(spec, s, scenes, res.timing)
                    res.notes = scene.notes
                meta, rejected = _new_trajectory(scene, gnm, s, spec, split, name, index, res)
                reasons.update(rejected)
                if meta is None:
                    if not kept:
                        raise SceneError(_diagnose(s, scene.scene.scene_id, rejected,
                                                   scene.ctx.stats["max_geodesic_seen"]))
                    failed.append({"index": index, "rejected": dict(sorted(rejected.items()))})
            if meta is not None:
                kept.append(meta)
            if on_trajectory:
                on_trajectory(1)
        if scene is None:  # everything was on disk but the record was not: load for the map
            scene = _Scene(spec, s, scenes, res.timing)
        res.record = _close_scene(gnm, scene, res, split, s.kind, trajectories_per_scene, kept, failed, reasons)
        return res
    finally:
        if scene is not None:
            scene.close()


def _new_trajectory(scene: _Scene, gnm: GNMWriter, s: GenSettings, spec: str, split: str, name: str, index: int,
                    res: SceneResult) -> tuple[dict | None, Counter]:
    """Trajectory ``index``: the first of ``max_attempts`` draws the expert (or the negative rule)
    keeps, rendered and written as folder ``name``. Returns (its sidecar, or None when every
    attempt was rejected; the rejections by reason); adds to ``res``' timings and counts."""
    rejected = Counter()
    rollout = None
    t0 = time.perf_counter()
    for a in range(s.max_attempts):
        out = attempt(scene.ctx, naming.attempt_rng(s.seed, s.kind, res.slug, index, a))
        if isinstance(out, Rollout):
            rollout = out
            break
        rejected[out] += 1
    res.timing["planning"] += time.perf_counter() - t0
    if rollout is None:
        return None, rejected
    jpegs, depth = _render(scene.renderer, rollout, s, res.timing)
    t0 = time.perf_counter()
    meta = _meta(s, scene.scene.scene_id, spec, split, name, index, a, rejected, rollout, scene.renderer.backend)
    gnm.write_trajectory(name, jpegs, rollout.planar, rollout.yaws, meta, depth)
    res.timing["writing"] += time.perf_counter() - t0
    res.written += 1
    res.frames += len(jpegs)
    return meta, rejected


def _close_scene(gnm: GNMWriter, scene: _Scene, res: SceneResult, split: str, kind: str, trajectories_per_scene: int,
                 kept: list[dict], failed: list[dict], reasons: Counter) -> dict:
    """Write the scene's map and, last, its record (`GNMWriter.close_scene`); returns the record."""
    t0 = time.perf_counter()
    gnm.write_map(res.slug, _map_png(gnm.out_dir, scene, kept))
    rec = {
        "scene": scene.scene.scene_id, "spec": res.spec, "slug": res.slug, "split": split, "kind": kind,
        "trajectories_per_scene": trajectories_per_scene,
        "trajectories": [{"name": m["name"], "index": m["index"], "frames": m["frames"], "t_c": m["t_c"],
                          "path_length": m["path_length"], "attempt": m["attempt"]} for m in kept],
        "failed": failed, "rejected": dict(sorted(reasons.items())),
        "attempts": int(sum(reasons.values()) + len(kept)),
        "renderers": sorted({m["renderer"] for m in kept}),
    }
    gnm.close_scene(res.slug, rec)
    res.timing["writing"] += time.perf_counter() - t0
    return rec


def _render(renderer, r: Rollout, s: GenSettings, timing: dict) -> tuple[list[bytes], np.ndarray | None]:
    """JPEG bytes of every frame and, with dataset.save_depth, the depth maps float16 [T, S, S]. Frames
    are rendered CALL_VIEWS at a time (`Renderer.render_batch`: the same images as one by one)."""
    jpegs, depths = [], []
    for k in range(0, r.num_render, CALL_VIEWS):
        t0 = time.perf_counter()
        poses = [(r.positions[i], float(r.yaws[i])) for i in range(k, min(k + CALL_VIEWS, r.num_render))]
        rgb, depth = renderer.render_batch(poses, depth=s.save_depth)
        t1 = time.perf_counter()
        for j in range(len(poses)):
            jpegs.append(writer.encode_jpeg(rgb[j], s.jpeg_quality))
            if s.save_depth:
                depths.append(writer.downsample_depth(depth[j], s.depth_size))
        timing["rendering"] += t1 - t0
        timing["encoding"] += time.perf_counter() - t1
    jpegs += [jpegs[-1]] * (len(r.yaws) - r.num_render)  # I_t = I_{t_c} after the collision
    if not s.save_depth:
        return jpegs, None
    depths += [depths[-1]] * (len(r.yaws) - r.num_render)  # and so is its depth
    return jpegs, np.stack(depths)


def _navigable_on(grid, navmesh, floor_y: float) -> np.ndarray:
    """The navmesh's sampled islands resampled on the occupancy grid's cells, from its cells on the floor at
    ``floor_y`` (the floor the grid is at: `rvn_data.dataset.floors.floor_grid`)."""
    ng = floor_grid(navmesh, floor_y)
    rows, cols = np.indices(grid.shape)
    rc = ng.world_to_grid(grid.to_world(np.stack([rows, cols], -1)))
    inside = ng.contains(rc)
    out = np.zeros(grid.shape, bool)
    out[inside] = np.isin(ng.island[rc[inside][:, 0], rc[inside][:, 1]], navmesh.sampled_islands)
    return out


def _map_png(out_dir: Path, scene: _Scene, kept: list[dict]) -> bytes:
    """Top-down map of the scene with every kept trajectory and its collision point: a panel a floor the trajectories
    start on, lowest first (`rvn_data.dataset.floors`: one unless the sampled islands lie on several floors)."""
    nav = scene.ctx.navmesh
    floors = by_floor(nav, [np.asarray(m["start"], dtype=np.float64) for m in kept])
    panels = []
    for floor_y, members in floors or [(floor_heights(nav)[0], [])]:
        group = [kept[i] for i in members]
        grid, free = scene.ctx.grid_at(floor_y)
        trajs = []
        for m in group:
            planar = load_traj_data(out_dir / m["name"])[0]
            hit = None
            if m["t_c"] is not None:
                hit = m["contact"] or [planar[m["t_c"]][0], m["start"][1], -planar[m["t_c"]][1]]
            trajs.append({"planar": planar, "start": m["start"], "goal": m["goal"], "collision": hit})
        caption = f"floor at y = {floor_y:.2f} m: {len(group)} trajectories" if len(floors) > 1 else None
        panels.append((grid, free, _navigable_on(grid, nav, floor_y), trajs, caption))
    return render_panels(panels, "off main island" if nav.sampled_islands == [0] else "off the sampled islands")
