"""Figures and animations of collision clips (matplotlib `Figure` objects, no pyplot state).

- `clip_figure`: the clip's frames in a grid beside the map with the path and a legend of
  its marks (`rvn_data.inspect.maps.LEGEND`); the collision frame has a red border, frames
  after it (frozen at I_{t_c}) are labelled so.
- `animation_frames` / `write_animation`: per step, the frame (scaled up) beside the map
  cropped around the clip with the path so far and the current pose, a legend strip under
  both; GIF (PIL) or MP4 (OpenCV), written under a temporary name and moved into place.
- `stats_figure`: trajectory lengths, t_c, path lengths and collisions per scene.
"""
from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
from matplotlib.figure import Figure
from matplotlib.ticker import MaxNLocator

from rvn_data.atomic import atomic_path
from rvn_data.inspect.clips import Clip
from rvn_data.dataset.topdown import legend_strip
from rvn_data.inspect.maps import LEGEND, SceneMap, draw_clip

RED = (220, 0, 0)


def _label(clip: Clip, t: int) -> str:
    if clip.t_c is None or t < clip.t_c:
        return f"t={t}"
    return f"t={t} = t_c" if t == clip.t_c else f"t={t} (frozen)"


def _around(clip: Clip, smap: SceneMap, pad: float) -> SceneMap:
    """The map cropped ``pad`` m around the clip's poses and its goal."""
    pts = [clip.planar] + ([np.asarray([clip.meta["goal_planar"]])] if clip.meta.get("goal_planar") is not None else [])
    return smap.crop(np.concatenate(pts), pad)


def clip_figure(clip: Clip, smap: SceneMap, cols: int = 5, frame_inches: float = 1.6, pad: float = 1.5) -> Figure:
    """Frames of ``clip`` in a grid (``cols`` per row) beside the map (cropped ``pad`` m around
    the clip and its goal) with the path, the pose at t_c and the contact point."""
    n = len(clip)
    rows = max(1, int(np.ceil(n / cols)))
    map_img = draw_clip(_around(clip, smap, pad), clip.meta, clip.planar, t_c=clip.t_c, yaw=clip.yaw)
    aspect = map_img.shape[1] / map_img.shape[0]
    map_w = rows * frame_inches * aspect
    fig = Figure(figsize=(cols * frame_inches + map_w, rows * frame_inches + 1.0), layout="constrained")
    grid = fig.add_gridspec(rows, cols + 1, width_ratios=[1.0] * cols + [map_w / frame_inches])
    for t in range(rows * cols):
        ax = fig.add_subplot(grid[t // cols, t % cols])
        ax.set_xticks([])
        ax.set_yticks([])
        if t >= n:
            ax.axis("off")
            continue
        ax.imshow(clip.frames[t])
        hit = clip.t_c is not None and t == clip.t_c
        ax.set_title(_label(clip, t), fontsize=7, color="red" if hit else "black")
        for spine in ax.spines.values():
            spine.set_color("red" if hit else "0.7")
            spine.set_linewidth(3 if hit else 0.5)
    ax = fig.add_subplot(grid[:, cols])
    ax.imshow(map_img)
    ax.set_xticks([])
    ax.set_yticks([])
    fig.legend(handles=legend_handles(), loc="outside lower right", ncol=4, fontsize=7, frameon=False,
               handlelength=2.2)
    tc = "none" if clip.t_c is None else f"{clip.t_c} of {n} frames ({clip.meta.get('t_c_episode')} steps from start)"
    fig.suptitle(f"{clip.name} ({clip.scene}): collision frame {tc}", fontsize=9)
    return fig


def legend_handles() -> list:
    """Matplotlib legend entries of `draw_clip`'s marks (`rvn_data.inspect.maps.LEGEND`)."""
    from matplotlib.lines import Line2D

    style = {"thin": {"lw": 1}, "line": {"lw": 2}, "dashed": {"lw": 2, "ls": (0, (2, 2))},
             "dot": {"ls": "", "marker": "o", "ms": 5}, "square": {"ls": "", "marker": "s", "ms": 5},
             "ring": {"ls": "", "marker": "o", "ms": 7, "mfc": "none", "mew": 1.5},
             "cross": {"ls": "", "marker": "x", "ms": 6, "mew": 1.5},
             "arrow": {"ls": "", "marker": r"$\rightarrow$", "ms": 10}}
    return [Line2D([], [], color=tuple(c / 255 for c in colour), label=text, **style[icon])
            for icon, colour, text in LEGEND]


def animation_frames(clip: Clip, smap: SceneMap, height: int = 256, pad: float = 1.5) -> list[np.ndarray]:
    """One RGB image per step: frame t (nearest-neighbour scaled to ``height``) beside the
    map cropped ``pad`` m around the clip, path up to t; red border from t_c on; the legend
    of the map's marks under both."""
    local = _around(clip, smap, pad)
    out, legend = [], None
    for t in range(len(clip)):
        frame = clip.frames[t]
        w = int(round(frame.shape[1] * height / frame.shape[0]))
        left = cv2.resize(frame, (w, height), interpolation=cv2.INTER_NEAREST)
        right = draw_clip(local, clip.meta, clip.planar, upto=t, t_c=clip.t_c, yaw=clip.yaw)
        mw = max(1, int(round(right.shape[1] * height / right.shape[0])))
        right = cv2.resize(right, (mw, height), interpolation=cv2.INTER_AREA)
        img = np.concatenate([left, np.full((height, 4, 3), 255, np.uint8), right], 1)
        hit = clip.t_c is not None and t >= clip.t_c
        if hit:
            cv2.rectangle(img, (0, 0), (w - 1, height - 1), RED, 4)
        cv2.putText(img, _label(clip, t), (6, 18), cv2.FONT_HERSHEY_SIMPLEX, 0.5, (0, 0, 0), 3, cv2.LINE_AA)
        cv2.putText(img, _label(clip, t), (6, 18), cv2.FONT_HERSHEY_SIMPLEX, 0.5, RED if hit else (255, 255, 255), 1,
                    cv2.LINE_AA)
        if legend is None or legend.shape[1] != img.shape[1]:
            legend = legend_strip(img.shape[1], LEGEND)
        out.append(np.concatenate([img, legend], 0))
    return out


def write_animation(frames: list[np.ndarray], path: str | Path, fps: float = 3.0) -> Path:
    """Write RGB frames as an animated GIF (``.gif``, PIL, loops) or MP4 (``.mp4``, OpenCV
    mp4v); atomically."""
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in (".gif", ".mp4"):
        raise ValueError(f"animation {path}: use a .gif or .mp4 file name")
    if not frames:
        raise ValueError(f"animation {path}: no frames")
    with atomic_path(path) as tmp:
        if suffix == ".gif":
            from PIL import Image

            images = [Image.fromarray(f) for f in frames]
            images[0].save(tmp, format="GIF", save_all=True, append_images=images[1:], duration=int(1000 / fps),
                           loop=0)
        else:
            h, w = frames[0].shape[:2]
            writer = cv2.VideoWriter(str(tmp), cv2.VideoWriter_fourcc(*"mp4v"), float(fps), (w - w % 2, h - h % 2))
            if not writer.isOpened():
                raise ValueError(f"animation {path}: OpenCV cannot write MP4 here; use a .gif name")
            for f in frames:
                writer.write(np.ascontiguousarray(f[: h - h % 2, : w - w % 2, ::-1]))
            writer.release()
    return path


def stats_figure(stats: dict) -> Figure:
    """2×2 panels: frames per trajectory, collision frame t_c (and steps before it), A* path
    lengths, collisions per scene (from `rvn_data.inspect.clips.dataset_stats`)."""
    fig = Figure(figsize=(10, 7), layout="constrained")
    axes = fig.subplots(2, 2)
    ax = axes[0, 0]
    frames = stats["frames"]
    ax.hist(frames, bins=np.arange(frames.min(), frames.max() + 2) - 0.5 if len(frames) else 10, color="tab:blue")
    ax.set(title=f"trajectory length ({len(frames)} trajectories)", xlabel="frames", ylabel="trajectories")
    ax = axes[0, 1]
    if len(stats["t_c"]):
        ax.hist(stats["t_c"], bins=np.arange(stats["t_c"].max() + 2) - 0.5, color="tab:red", label="t_c in clip")
        if len(stats["t_c_episode"]):
            ax.hist(stats["t_c_episode"], bins=20, color="tab:orange", alpha=0.5, label="steps from start")
        ax.legend(fontsize=8)
    ax.set(title=f"collision step ({len(stats['t_c'])} collisions)", xlabel="step", ylabel="trajectories")
    ax = axes[1, 0]
    ax.hist(stats["path_length"], bins=20, color="tab:green", label="A* path")
    if len(stats["geodesic"]):
        ax.hist(stats["geodesic"], bins=20, color="tab:gray", alpha=0.5, label="geodesic start-goal")
    ax.legend(fontsize=8)
    ax.set(title="path length", xlabel="m", ylabel="trajectories")
    ax = axes[1, 1]
    scenes = list(stats["per_scene"])
    ax.bar(range(len(scenes)), [stats["per_scene"][s] for s in scenes], color="tab:red")
    ax.set_xticks(range(len(scenes)), scenes, rotation=60, ha="right", fontsize=7 if len(scenes) < 20 else 5)
    ax.yaxis.set_major_locator(MaxNLocator(integer=True))
    ax.set(title="collisions per scene", ylabel="collisions")
    return fig


__all__ = ["animation_frames", "clip_figure", "stats_figure", "write_animation"]
