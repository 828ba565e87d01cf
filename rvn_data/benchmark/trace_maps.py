"""Pictures of an rvn-eval run from its episodes' traces (``paths=true``; `rvn_data.benchmark.traces`): where each
episode went and how it ended, a map a scene (``out_dir/maps/<scene>.png``), and the last steps before a collision
as a clip (``out_dir/clips/<scene>-<episode>-collision.gif``; the last steps of a timed-out one with
``--timeout-clips N``). rvn-eval draws the maps at the end of a run with
``paths=true``; ``python -m rvn_data.benchmark.trace_maps RUN_DIR [--clips N]`` draws them again from the folder
(its ``run.json`` gives the scene options, navmesh and camera), and with ``--clips N`` the clips of its first N
collisions.

A map draws a panel a floor the episodes start on (`rvn_data.dataset.floors`; stairs join floors into one island, so
floors are told apart by height), lowest first: white = where the robot's centre may be,
light grey = floor within r_robot of an obstacle, dark = obstacle or no floor. Each episode is a coloured path from
its start (green dot) through the goals it reached (blue squares) to where it ended: a collision (red cross), a
timeout (orange ring) or its last goal; the goal a failed episode was heading for is a hollow blue square. A clip
shows the agent's view over its last ``k_pre`` = 8 steps before the collision and the colliding step (red frame),
or a timed-out episode's last 16 (the final view framed orange: is it turning in place, wavering, stuck?),
enlarged to at least 192 px, beside the map with the agent's pose.
"""
from __future__ import annotations

import argparse
import json
import math
import re
from pathlib import Path

import cv2
import numpy as np

from rvn_data.atomic import write_bytes_atomic
from rvn_data.benchmark.traces import FOLDER, read_trace
from rvn_data.dataset.floors import by_floor, floor_grid, floor_heights, nearest_floor
from rvn_data.dataset.topdown import (COLLISION, GOAL, START, encode_png, legend_strip, path_colour,
                                      side_by_side)

SCALE = 2  # output pixels per navmesh cell
TIMEOUT = (0, 140, 255)  # BGR orange
NAVIGABLE, NEAR, BLOCKED = (255, 255, 255), (215, 215, 215), (60, 60, 60)
K_PRE = 8  # steps before a collision a clip shows (the negative datasets' k_pre)


def load_traces(out_dir: str | Path) -> list[dict]:
    """Every trace of a run folder, in (scene, episode) order, each with its file's ``name`` (`traces.trace_file`)."""
    return [dict(read_trace(p), name=p.stem) for p in sorted((Path(out_dir) / FOLDER).glob("*.npz"))]


def _panel(layer, traces: list[dict], first: int) -> np.ndarray:
    img = np.full(layer.shape + (3,), BLOCKED, np.uint8)
    img[layer.free] = NEAR
    img[layer.island >= 0] = NAVIGABLE
    img = cv2.resize(img, (layer.shape[1] * SCALE, layer.shape[0] * SCALE), interpolation=cv2.INTER_NEAREST)

    def px(world) -> np.ndarray:
        w = np.asarray(world, np.float64).reshape(-1, 3)
        return np.round(np.stack([(w[:, 0] - layer.x0) / layer.cs * SCALE,
                                  (w[:, 2] - layer.z0) / layer.cs * SCALE], -1)).astype(np.int32)

    for i, t in enumerate(traces):
        cv2.polylines(img, [px(t["positions"]).reshape(-1, 1, 2)], False, path_colour(first + i), 1, cv2.LINE_AA)
    for t in traces:
        reached = int(t["goals_reached"][-1])
        s = px(t["positions"][0])[0]
        cv2.circle(img, (int(s[0]), int(s[1])), 4, START, -1, cv2.LINE_AA)
        for g in px(t["goals"][:reached]):
            cv2.rectangle(img, (int(g[0]) - 3, int(g[1]) - 3), (int(g[0]) + 3, int(g[1]) + 3), GOAL, -1)
        if t["termination"] != "success" and reached < len(t["goals"]):
            g = px(t["goals"][reached])[0]
            cv2.rectangle(img, (int(g[0]) - 4, int(g[1]) - 4), (int(g[0]) + 4, int(g[1]) + 4), GOAL, 1)
        e = px(t["positions"][-1])[0]
        if t["termination"] == "collision":
            cv2.drawMarker(img, (int(e[0]), int(e[1])), COLLISION, cv2.MARKER_TILTED_CROSS, 10, 2)
        elif t["termination"] == "timeout":
            cv2.circle(img, (int(e[0]), int(e[1])), 5, TIMEOUT, 2, cv2.LINE_AA)
    return img


def trace_legend(width: int) -> np.ndarray:
    return legend_strip(width, [("dot", START, "start"), ("square", GOAL, "goal reached"),
                                ("hollow", GOAL, "goal not reached"), ("line", path_colour(0), "path (one colour each)"),
                                ("cross", COLLISION, "collision"), ("ring", TIMEOUT, "timeout"),
                                ("swatch", NAVIGABLE, "navigable"), ("swatch", NEAR, "floor near obstacles"),
                                ("swatch", BLOCKED, "obstacle / no floor")])


def scene_map(navmesh, traces: list[dict]) -> bytes:
    """PNG bytes of one scene's map: a panel a floor its episodes start on, lowest first (`rvn_data.dataset.floors`)."""
    floors = by_floor(navmesh, [t["positions"][0].astype(np.float64) for t in traces])
    images, captions, first = [], [], 0
    for floor_y, members in floors:
        group = [traces[i] for i in members]
        images.append(_panel(floor_grid(navmesh, floor_y), group, first))
        first += len(group)
        ends = {e: sum(t["termination"] == e for t in group) for e in ("success", "collision", "timeout")}
        where = f"floor y = {floor_y:.2f} m" if len(floors) > 1 else navmesh.scene_id
        captions.append(f"{where}: {len(group)} episodes, {ends['success']} succeeded, {ends['collision']} collided, "
                        f"{ends['timeout']} timed out")
    img = side_by_side(images, captions)
    return encode_png(np.concatenate([img, trace_legend(img.shape[1])], 0))


def _slug(text: str) -> str:
    return re.sub(r"[^A-Za-z0-9_.-]+", "_", text).strip("_.")[-80:] or "scene"


def draw_maps(out_dir: str | Path, scenes: dict, navmesh_settings, cache_dir: str | Path | None = None,
              traces: list[dict] | None = None) -> list[Path]:
    """Write ``out_dir/maps/<scene>.png`` for every scene with traces (``traces``: `load_traces`'s, when read
    already); the paths written."""
    from rvn_data.navmesh.source import open_scene

    by_scene: dict[str, list[dict]] = {}
    for t in load_traces(out_dir) if traces is None else traces:
        by_scene.setdefault(t["spec"], []).append(t)
    written = []
    for spec, traces in by_scene.items():
        _, navmesh = open_scene(spec, scenes, navmesh_settings, cache_dir)
        path = Path(out_dir) / "maps" / f"{_slug(traces[0]['scene_id'])}.png"
        write_bytes_atomic(path, scene_map(navmesh, traces))
        written.append(path)
    return written


CLIPS = {"collision": (K_PRE, (230, 0, 0)), "timeout": (2 * K_PRE, (255, 140, 0))}  # steps shown before the end, RGB


def draw_clips(out_dir: str | Path, scenes: dict, navmesh_settings, camera, counts: dict[str, int],
               backend: str = "auto", cache_dir: str | Path | None = None, suffix: str = ".gif",
               traces: list[dict] | None = None) -> list[Path]:
    """Write ``out_dir/clips/<scene>-<episode>-<ending>.gif`` for the first ``counts[ending]`` episodes that ended so
    (``collision``: the last 8 steps and the colliding one, framed red; ``timeout``: the last 16, the final view framed
    orange; ``suffix`` ".mp4": MP4 files instead; ``traces``: `load_traces`'s, when read already); the paths
    written."""
    from rvn_data.inspect.plots import write_animation
    from rvn_data.navmesh.source import open_scene
    from rvn_data.render import make_renderer

    unknown = sorted(set(counts) - set(CLIPS))
    if unknown:
        raise ValueError(f"clips of {unknown}: the endings with clips are {sorted(CLIPS)}")
    chosen, left = [], dict(counts)
    for t in load_traces(out_dir) if traces is None else traces:
        if left.get(t["termination"], 0) > 0:
            left[t["termination"]] -= 1
            chosen.append(t)
    written, spec, renderer = [], None, None  # the scene of the clips in hand (traces come by scene)
    try:
        for t in chosen:
            if t["spec"] != spec:
                if renderer is not None:
                    renderer.close()
                spec, renderer = t["spec"], None
                scene, navmesh = open_scene(spec, scenes, navmesh_settings, cache_dir)
                renderer = make_renderer(scene, camera, backend=backend)
                floors, panels = floor_heights(navmesh), {}  # a floor's panel made once for the scene's clips
            y = nearest_floor(floors, t["positions"][0][1])
            if y not in panels:
                panels[y] = floor_grid(navmesh, y)
            steps, colour = CLIPS[t["termination"]]
            frames = _clip_frames(panels[y], renderer, t, steps, colour)
            name = f"{_slug(t['scene_id'])}-{t['name'].split('-')[1]}-{t['termination']}{suffix}"
            written.append(write_animation(frames, Path(out_dir) / "clips" / name, fps=2.0))
    finally:
        if renderer is not None:
            renderer.close()
    return written


def _clip_frames(layer, renderer, t: dict, steps: int, colour: tuple) -> list[np.ndarray]:
    """RGB frames: the view at each of the last ``steps`` + 1 poses (the last one framed in ``colour``), enlarged,
    beside the map of the episode (on ``layer``, its floor's `floor_grid`) with the pose so far."""
    n = len(t["positions"])
    first = max(0, n - 1 - steps)
    positions, yaws = t["positions"][first:].astype(np.float64), t["yaws"][first:].astype(np.float64)
    views = [renderer.render(p, float(y), depth=False)[0] for p, y in zip(positions, yaws)]
    h, w = views[0].shape[:2]
    zoom = max(1, math.ceil(192 / max(h, w)))
    base = cv2.cvtColor(_panel(layer, [t], 0), cv2.COLOR_BGR2RGB)
    lo = np.floor(np.stack([(positions[:, 0] - layer.x0), (positions[:, 2] - layer.z0)], -1).min(0) / layer.cs * SCALE)
    hi = np.ceil(np.stack([(positions[:, 0] - layer.x0), (positions[:, 2] - layer.z0)], -1).max(0) / layer.cs * SCALE)
    size = h * zoom
    c = ((lo + hi) / 2).astype(int)
    r0, c0 = np.clip([c[1] - size // 2, c[0] - size // 2], 0, None)
    crop = base[r0:r0 + size, c0:c0 + size]
    crop = cv2.copyMakeBorder(crop, 0, size - crop.shape[0], 0, size - crop.shape[1], cv2.BORDER_CONSTANT,
                              value=BLOCKED)
    frames = []
    for i, (view, p, yaw) in enumerate(zip(views, positions, yaws)):
        big = cv2.resize(view, (w * zoom, h * zoom), interpolation=cv2.INTER_NEAREST)
        if i == len(views) - 1:
            cv2.rectangle(big, (0, 0), (big.shape[1] - 1, big.shape[0] - 1), colour, 4)
        m = crop.copy()
        x, z = (p[0] - layer.x0) / layer.cs * SCALE - c0, (p[2] - layer.z0) / layer.cs * SCALE - r0
        tip = (int(x + 10 * math.cos(yaw)), int(z - 10 * math.sin(yaw)))
        cv2.arrowedLine(m, (int(x), int(z)), tip, (0, 0, 0), 2, cv2.LINE_AA, tipLength=0.4)
        frames.append(np.concatenate([big, np.full((size, 4, 3), 255, np.uint8), m], 1))
    return frames


def main(argv: list[str] | None = None) -> None:
    from rvn_data.cache_root import cache_root
    from rvn_data.cli.common import ConfigError, fail
    from rvn_data.navmesh.settings import NavMeshSettings
    from rvn_data.render import CameraConfig

    ap = argparse.ArgumentParser(prog="python -m rvn_data.benchmark.trace_maps", description=__doc__.split("\n\n")[0])
    ap.add_argument("run_dir", help="an rvn-eval out_dir of a run with paths=true")
    ap.add_argument("--clips", type=int, default=0, metavar="N", help="also a clip of each of the first N collisions")
    ap.add_argument("--timeout-clips", type=int, default=0, metavar="N",
                    help="also a clip of the last 16 steps of each of the first N timed-out episodes")
    ap.add_argument("--backend", choices=("auto", "gl", "raycast"), default="auto", help="renderer of the clips")
    ap.add_argument("--format", choices=("gif", "mp4"), default="gif", help="the clips' file format")
    ap.add_argument("--cache-dir", default=None,
                    help="cache root whose navmesh/ the scenes' navmeshes are read from and kept in, as rvn-eval's "
                         "cache_dir= (default: $RVN_CACHE_DIR, else RUN_DIR/cache)")
    args = ap.parse_args(argv)
    run = Path(args.run_dir)
    try:
        if not (run / "run.json").is_file():
            raise ConfigError(f"{run}: no run.json; give the out_dir of an rvn-eval run")
        if not any((run / FOLDER).glob("*.npz")):
            raise ConfigError(f"{run}: no episode traces in {run / FOLDER}; run rvn-eval with paths=true")
        for flag, value in (("--clips", args.clips), ("--timeout-clips", args.timeout_clips)):
            if value < 0:
                raise ConfigError(f"{flag} {value} must be >= 0")
        cfg = json.loads((run / "run.json").read_text())
        scenes = {k: v for k, v in cfg["scenes"].items() if k in ("up_axis", "unit_scale", "level", "source")}
        navmesh = NavMeshSettings.from_config(cfg["navmesh"])
        root, traces = cache_root(args.cache_dir, run), load_traces(run)
        maps = draw_maps(run, scenes, navmesh, root, traces)
        counts = {"collision": args.clips, "timeout": args.timeout_clips}
        clips = draw_clips(run, scenes, navmesh, CameraConfig(**cfg["camera"]), counts, args.backend,
                           root, f".{args.format}", traces) if any(counts.values()) else []
    except (ValueError, OSError) as err:
        fail("trace_maps", err)
    print(f"wrote {len(maps)} map(s) in {run / 'maps'}" + (f" and {len(clips)} clip(s) in {run / 'clips'}" if clips else ""))


if __name__ == "__main__":
    main()
