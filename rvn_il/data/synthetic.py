"""A small synthetic GNM dataset for tests, benchmarks and demos (no simulator needed).

Each trajectory is a random walk of the discrete actions (MOVE_FORWARD d_step, TURN_LEFT /
TURN_RIGHT θ_step) from a random pose, so poses obey the GNM format's frame exactly. Frames are
real JPEGs that depend on the pose: a sky/floor split whose colours follow the yaw and a
vertical landmark drawn at the bearing of a fixed world point.
"""
from __future__ import annotations

import math
import pickle
from pathlib import Path

import cv2
import numpy as np
import yaml

from rvn_data.conventions import AgentConfig

LANDMARK = np.array([3.0, 2.0])


def render_frame(position: np.ndarray, yaw: float, size: int = 64) -> np.ndarray:
    """uint8 RGB [size,size,3] view of the toy world from a planar pose."""
    img = np.zeros((size, size, 3), np.uint8)
    hue = (np.array([np.cos(yaw), np.cos(yaw + 2.1), np.cos(yaw + 4.2)]) * 0.5 + 0.5) * 200 + 30
    img[: size // 2] = hue.astype(np.uint8)
    img[size // 2:] = (255 - hue).astype(np.uint8) // 2
    d = LANDMARK - position
    bearing = math.atan2(d[1], d[0]) - yaw
    bearing = (bearing + math.pi) % (2 * math.pi) - math.pi
    if abs(bearing) < math.radians(45):
        col = int((0.5 - bearing / math.radians(90)) * (size - 1))
        half = max(1, int(size / (2 + np.linalg.norm(d))))
        img[size // 2 - half: size // 2 + half, max(0, col - 2): col + 3] = (255, 40, 40)
    return img


def random_walk(rng: np.random.Generator, length: int, d_step: float = AgentConfig.d_step, theta_step_deg: float = AgentConfig.theta_step_deg,
                p_forward: float = 0.7) -> tuple[np.ndarray, np.ndarray]:
    """(position float64 [T,2], yaw float64 [T]) of a random discrete-action walk."""
    pos, yaw = [rng.uniform(-2, 2, size=2)], [float(rng.uniform(-math.pi, math.pi))]
    theta = math.radians(theta_step_deg)
    for _ in range(length - 1):
        p, y = pos[-1], yaw[-1]
        u = rng.random()
        if u < p_forward:
            pos.append(p + d_step * np.array([math.cos(y), math.sin(y)]))
            yaw.append(y)
        else:
            pos.append(p.copy())
            yaw.append(y + (theta if u < (1 + p_forward) / 2 else -theta))
    return np.array(pos, dtype=np.float64), np.array(yaw, dtype=np.float64)


def write_synthetic_gnm(root: str | Path, num_trajectories: int = 4, length: int | tuple[int, int] = 24,
                        image_size: int | tuple[int, int] = 64, seed: int = 0, spacing: float = AgentConfig.d_step,
                        test_fraction: float = 0.0, pose_noise: float = 0.0, name: str | None = None) -> Path:
    """Write ``num_trajectories`` GNM trajectory folders, data_config.yaml and data_splits. Foreign data as
    real datasets come: ``image_size`` (width, height) other than square, ``pose_noise`` (m, Gaussian odometry
    noise on every position), ``name``: data_config.yaml keyed by that dataset name (visualnav-transformer's
    layout) instead of the top-level entry."""
    root = Path(root)
    rng = np.random.default_rng(seed)
    width, height = (image_size, image_size) if isinstance(image_size, int) else (int(image_size[0]), int(image_size[1]))
    names = []
    for i in range(num_trajectories):
        n = int(rng.integers(length[0], length[1] + 1)) if isinstance(length, tuple) else int(length)
        position, yaw = random_walk(rng, n, d_step=spacing)
        if pose_noise:
            position = position + rng.normal(0.0, pose_noise, position.shape)
        traj = f"traj_{seed:03d}_{i:04d}"
        folder = root / traj
        folder.mkdir(parents=True, exist_ok=True)
        for t in range(n):
            rgb = render_frame(position[t], yaw[t], width)
            if height != width:
                rgb = cv2.resize(rgb, (width, height), interpolation=cv2.INTER_AREA)
            cv2.imwrite(str(folder / f"{t}.jpg"), cv2.cvtColor(rgb, cv2.COLOR_RGB2BGR), [cv2.IMWRITE_JPEG_QUALITY, 90])
        with open(folder / "traj_data.pkl", "wb") as f:
            pickle.dump({"position": position, "yaw": yaw}, f)
        names.append(traj)
    entry = {"metric_waypoint_spacing": spacing}
    (root / "data_config.yaml").write_text(yaml.safe_dump({name: entry} if name else entry))
    n_test = int(round(test_fraction * len(names)))
    for split, part in (("train", names[n_test:]), ("test", names[:n_test])):
        d = root / "data_splits" / (name or root.name) / split
        d.mkdir(parents=True, exist_ok=True)
        (d / "traj_names.txt").write_text("".join(f"{n}\n" for n in part))
    return root
