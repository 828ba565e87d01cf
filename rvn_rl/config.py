"""Settings of an rvn-rl run: validation (one-line errors naming the setting), the
`RVNEnv` keyword arguments of the train-mode environments, the network's keyword arguments."""
from __future__ import annotations

from pathlib import Path

ALGOS = ("ppo", "ppo_lag", "ddppo", "ddppo_depth")
CONF_RL = Path(__file__).resolve().parents[1] / "conf" / "rl"


def _positive_int(value, name: str) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or value < 1:
        raise ValueError(f"{name}={value!r} must be a positive integer")
    return value


def validate(cfg: dict, world_size: int = 1) -> None:
    algo = cfg["algo"]
    if algo.get("name") not in ALGOS:
        raise ValueError(f"algo={algo.get('name')!r} is not an RL algorithm; choose one of {', '.join(ALGOS)}")
    env, ppo = cfg["env"], cfg["ppo"]
    for key in ("num_envs", "size", "scene_switch_every", "t_max"):
        _positive_int(env[key], f"env.{key}")
    _positive_int(env["scene_cache"] + 1, "env.scene_cache + 1")
    camera = cfg.get("camera") or {}
    for key in ("width", "height"):  # conf/rl.yaml sets both to ${env.size}; a value given on its own would disagree
        if key in camera and camera[key] != env["size"]:
            raise ValueError(f"camera.{key}={camera[key]} differs from env.size={env['size']}: the observation is "
                             f"env.size pixels square; set env.size={camera[key]} (camera.width and height follow it)")
    workers = env.get("workers", 0)
    if isinstance(workers, bool) or not isinstance(workers, int) or not 0 <= workers <= env["num_envs"]:
        raise ValueError(f"env.workers={workers!r} must be between 0 (in process) and env.num_envs={env['num_envs']}")
    for key in ("num_steps", "ppo_epoch", "num_mini_batch"):
        _positive_int(ppo[key], f"ppo.{key}")
    if env["num_envs"] < ppo["num_mini_batch"]:
        raise ValueError(f"env.num_envs={env['num_envs']} is below ppo.num_mini_batch={ppo['num_mini_batch']}: "
                         "each mini-batch holds whole rollouts of some envs; raise env.num_envs or lower num_mini_batch")
    total = cfg["train"]["total_steps"]
    if isinstance(total, float) and total.is_integer():  # 4e5 on the command line
        total = cfg["train"]["total_steps"] = int(total)
    _positive_int(total, "train.total_steps")
    _positive_int(cfg["train"]["checkpoint_every"], "train.checkpoint_every")
    if cfg["model"]["backbone"] not in ("resnet18", "resnet50"):
        raise ValueError(f"model.backbone={cfg['model']['backbone']!r}: choose resnet50 or resnet18")
    if world_size > 1 and not algo["distributed"]:
        raise ValueError(f"algo={algo['name']} runs in one process; use algo=ddppo (or ddppo_depth) under torchrun")
    if not 0.0 < float(cfg["ddppo"]["sync_frac"]) <= 1.0:
        raise ValueError(f"ddppo.sync_frac={cfg['ddppo']['sync_frac']!r} must be in (0, 1]")
    if cfg["depth"]["source"] is True:  # depth.source=true parses as a YAML boolean
        cfg["depth"]["source"] = "true"
    if algo["use_depth"]:
        source = cfg["depth"]["source"]
        if source not in ("model", "true"):
            raise ValueError(f"depth.source={source!r}: choose model (predicted depth) or true (rendered depth)")
        if source == "model":
            path = cfg["depth"].get("model_path")
            if not path:
                raise ValueError("algo=ddppo_depth with depth.source=model needs depth.model_path=<trained depth "
                                 "model> (or depth.source=true for the rendered depth)")
            if not Path(str(path)).expanduser().exists():
                raise ValueError(f"depth.model_path={path}: no such file or directory")
    if algo["lagrangian"] and not float(algo["cost_limit"]) >= 0.0:
        raise ValueError(f"algo.cost_limit={algo['cost_limit']!r} must be >= 0")
    if algo["lagrangian"] and algo.get("lambda_max") is not None and not float(algo["lambda_max"]) > 0.0:
        raise ValueError(f"algo.lambda_max={algo['lambda_max']!r} must be > 0 (or null: no upper bound)")


def uses_true_depth(cfg: dict) -> bool:
    return bool(cfg["algo"]["use_depth"]) and cfg["depth"]["source"] == "true"


def env_kwargs(cfg: dict) -> dict:
    """`RVNEnv` keyword arguments of the train-mode environments."""
    env = cfg["env"]
    scenes = {k: v for k, v in dict(cfg["scenes"]).items() if k != "split"}
    return {"mode": "train", "split": "train", "scenes": scenes, "agent": cfg["agent"], "navmesh": cfg["navmesh"],
            "camera": cfg["camera"], "renderer": cfg.get("renderer") or {}, "episodes": dict(cfg["episodes"]),
            "t_max": env["t_max"], "scene_switch_every": env["scene_switch_every"],
            "goal_pool": int(env.get("goal_pool", 0)), "depth": bool(env.get("depth")) or uses_true_depth(cfg)}


def model_kwargs(cfg: dict) -> dict:
    """`PointNavResNetPolicy` keyword arguments (also what a checkpoint's config.yaml records)."""
    m = cfg["model"]
    return {"obs_size": int(cfg["env"]["size"]), "backbone": m["backbone"], "base_planes": int(m["base_planes"]),
            "ngroups": int(m["ngroups"]), "input_size": int(m["input_size"]), "hidden_size": int(m["hidden_size"]),
            "rnn_layers": int(m["rnn_layers"]), "use_depth": bool(cfg["algo"]["use_depth"]),
            "cost_critic": bool(cfg["algo"]["lagrangian"])}


def load_depth_fn(path: str, device="cpu"):
    """The frozen depth network of rvn_rl.depth: ``fn(rgb uint8 [N,H,W,3]) -> depth float32 [N,H,W]``."""
    from .depth import load_depth_model
    return load_depth_model(str(Path(str(path)).expanduser()), device=device)
