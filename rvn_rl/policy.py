"""A trained rvn-rl policy behind the benchmark's policy contract (``reset()``, ``act(obs)``):
``load_rl_policy(out_dir)`` rebuilds `PointNavResNetPolicy` from ``config.yaml`` and the
latest checkpoint's weights. The recurrent state, the previous action and the episode-start
mask reset in ``reset()``. rvn-eval refuses another camera than the training one (`rvn_data.embodiment`)
unless ``embodiment_mismatch=allow``; a frame of another size is then resized (area interpolation). Depth: the rendered ``obs["depth"]`` (``depth.source=true``, evaluate
with ``env.depth=true``) or the frozen depth model the run was trained with."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import torch

from rvn_data.embodiment import embodiment_of

from . import checkpoint as ck
from .model import PointNavResNetPolicy

POLICY_KEYS = {"deterministic", "threads", "depth_model_path", "env_steps"}


class RLPolicy:
    embodiment: dict | None = None  # the robot and camera of its training envs (rvn_data.embodiment), checked by rvn-eval
    loaded_files: dict | None = None  # {setting: folder} it read besides its checkpoint: counted in rvn-eval's run identity

    def __init__(self, net: PointNavResNetPolicy, obs_size: int, device: torch.device, deterministic: bool = False,
                 threads: int | None = 1, depth_fn=None, true_depth: bool = False):
        if threads is not None and (isinstance(threads, bool) or not isinstance(threads, int) or threads < 1):
            raise ValueError(f"policy threads={threads!r}; give a positive integer or null (torch's setting)")
        self.net, self.obs_size, self.device = net.eval(), int(obs_size), device
        self.deterministic, self.threads = bool(deterministic), threads
        self.depth_fn, self.true_depth = depth_fn, true_depth
        self.reset()

    def reset(self) -> None:
        self.state = self.net.initial_state(1, self.device)
        self.prev_action = torch.zeros(1, dtype=torch.long, device=self.device)
        self.mask = torch.zeros(1, device=self.device)

    def _resize(self, img: np.ndarray, interpolation) -> np.ndarray:
        if img.shape[0] == self.obs_size and img.shape[1] == self.obs_size:
            return img
        import cv2
        return cv2.resize(img, (self.obs_size, self.obs_size), interpolation=interpolation)

    def _tensors(self, obs: dict) -> dict:
        import cv2
        rgb = self._resize(np.asarray(obs["rgb"], dtype=np.uint8), cv2.INTER_AREA)
        out = {"rgb": torch.from_numpy(np.ascontiguousarray(rgb))[None].to(self.device),
               "pointgoal": torch.as_tensor(np.asarray(obs["pointgoal"], np.float32))[None].to(self.device)}
        if self.net.use_depth:
            if self.true_depth:
                if "depth" not in obs:
                    raise ValueError("this policy was trained on the rendered depth: evaluate with env.depth=true")
                depth = self._resize(np.asarray(obs["depth"], np.float32), cv2.INTER_NEAREST)
            else:
                depth = np.asarray(self.depth_fn(rgb[None]), np.float32)[0]
            out["depth"] = torch.from_numpy(np.ascontiguousarray(depth))[None].to(self.device)
        return out

    def act(self, obs: dict) -> int:
        old = torch.get_num_threads()
        if self.threads is not None and self.device.type == "cpu":
            torch.set_num_threads(self.threads)
        try:
            with torch.no_grad():
                action, _, _, self.state = self.net.act(self._tensors(obs), self.state, self.prev_action, self.mask,
                                                        deterministic=self.deterministic)
        finally:
            torch.set_num_threads(old)
        self.prev_action = action
        self.mask = torch.ones(1, device=self.device)
        return int(action[0])


def load_rl_policy(checkpoint_path: str | Path, device: str | torch.device = "cpu", model: str | None = None,
                   **overrides) -> RLPolicy:
    """`RLPolicy` from an rvn-rl ``out_dir``; keywords: ``deterministic`` (argmax instead of
    sampling, default false as habitat-baselines' evaluation), ``threads``, ``depth_model_path``
    (another frozen depth model than the training run's), ``env_steps`` (a kept checkpoint other than the
    latest: ``checkpoints/ckpt_<env_steps>``, e.g. to evaluate a run over its last few). ``model`` (optional)
    asserts the algo."""
    from rvn_il.policies.loader import resolve_device

    out_dir = Path(checkpoint_path).expanduser()
    cfg = ck.read_rl_config(out_dir)
    unknown = set(overrides) - POLICY_KEYS
    if unknown:
        raise ValueError(f"unknown RL policy setting(s) {sorted(unknown)}; valid: {sorted(POLICY_KEYS)}")
    if model is not None and model != cfg["algo"]["name"]:
        raise ValueError(f"checkpoint {out_dir} holds a {cfg['algo']['name']!r} policy, not {model!r}")
    ckpt = ck.latest(out_dir)
    if ckpt is None:
        raise ValueError(f"no checkpoint in {out_dir}/checkpoints: rvn-rl has not saved one yet")
    if overrides.get("env_steps") is not None:  # a kept checkpoint other than the latest
        ckpt = ck.checkpoint_at(out_dir, int(overrides["env_steps"]))
        if not (ckpt / "weights.safetensors").is_file():
            kept = [ck.env_steps_of(p) for p in ck.kept(out_dir) if (p / "weights.safetensors").is_file()]
            raise ValueError(f"{out_dir} keeps no checkpoint of {overrides['env_steps']} env steps (policy.env_steps); "
                             f"it keeps {', '.join(map(str, kept))}")
    dev = resolve_device(device, "policy.device")
    net = PointNavResNetPolicy(**cfg["policy"])
    ck.load_weights(net, ckpt)
    net = net.to(dev)
    depth_fn, true_depth = None, False
    if cfg["policy"]["use_depth"]:
        true_depth = cfg["depth"]["source"] == "true"
        if not true_depth:
            from .depth import load_depth_model
            depth_fn = load_depth_model(str(overrides.get("depth_model_path") or cfg["depth"]["model_path"]), device=dev)
    policy = RLPolicy(net, cfg["policy"]["obs_size"], dev, deterministic=bool(overrides.get("deterministic", False)),
                      threads=overrides.get("threads", 1), depth_fn=depth_fn, true_depth=true_depth)
    if cfg.get("agent") and cfg.get("camera"):  # the robot and camera it was trained with, checked by rvn-eval
        policy.embodiment = embodiment_of(cfg["agent"], cfg["camera"])
    policy.training_scenes = training_scenes(out_dir, cfg)
    if depth_fn is not None:  # the frozen depth model is part of what is evaluated
        policy.loaded_files = {"depth_model_path": str(depth_fn.folder)}
    return policy


def training_scenes(out_dir: Path, cfg: dict) -> dict | None:
    """The train scenes an rvn-rl run's config.yaml names (``scenes``, split train), as rvn-eval compares them with
    the scenes it evaluates (`rvn_data.benchmark.trained_scenes`): ``{"source": the config.yaml, "scenes": specs, or
    None where they cannot be listed here (a scene folder on another machine)}``; None for a config without
    ``scenes``."""
    from rvn_data.scenes.sets import scene_specs

    s = cfg.get("scenes")
    if not isinstance(s, dict):
        return None
    try:
        specs = scene_specs(s.get("source", "procedural"), "train", root=s.get("root"), num_scenes=s.get("num_scenes"),
                            first_scene=int(s.get("first_scene") or 0))
    except (ValueError, OSError, TypeError):  # a folder that is not here, a changed list: the check says unchecked
        specs = None
    return {"source": str(out_dir / "config.yaml"), "scenes": specs}
