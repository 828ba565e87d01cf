"""rvn-train's settings (conf/train.yaml): the typed schema of its config, every default here.

`TrainConfig` is registered in Hydra's ConfigStore as ``base_train`` (conf/train.yaml's first
default) by `register_schema`, which rvn-train calls before composing, so a typo'd ``data.*`` / ``train.*`` key or a value of
the wrong type stops rvn-train at start-up with Hydra's message. The model's settings are the
model's YAML (conf/model/<name>.yaml; `rvn_il.models.config`). Field order is the order of
the composed config, and so of the config.yaml rvn-train writes into its out_dir.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Mapping

from rvn_data.config import register, register_configs


@dataclass
class DatasetEntry:
    """One GNM dataset of ``data.datasets`` (several datasets at once, as visualnav-transformer's ``datasets:``;
    rvn_il/data/sources.py, docs/DATASET.md). Null settings take the ``data.*`` one of the same name."""

    root: str = "???"  # the GNM folder (the official config's data_folder)
    name: str | None = None  # dataset name (data_splits/<name>, data_config.yaml); null: the only one, else the folder's
    split: str | None = None  # data_splits/<name>/<split>/traj_names.txt; null: data.split
    splits_dir: str | None = None  # null: <root>/data_splits
    split_dir: str | None = None  # a folder holding traj_names.txt itself (the official config's train:); overrides split
    weight: float | None = None  # share of each batch (normalised over the list); null for all: in proportion to samples
    metric_waypoint_spacing: float | None = None  # m per frame; null: <root>/data_config.yaml, else d_step
    waypoint_spacing: int = 1  # frames between context frames, waypoints and goal steps (the official waypoint_spacing)
    goal_offset: list[int] | None = None  # null: data.goal_offset (in steps of waypoint_spacing frames)
    end_slack: int | None = None  # null: data.end_slack
    crop: str | None = None  # aspect | official | none; null: data.crop


@dataclass
class DataConfig:
    """``data``: the GNM datasets a model learns from and how samples are drawn from them."""

    root: str = "outputs/rvn_expert"  # GNM dataset (expert; rvn-gen default out_dir); nomad_neg: NoMaD_e data
    negative_root: str | None = "outputs/rvn_negative"  # nomad_neg only: negative GNM dataset (NoMaD_n)
    split: str = "train"  # data_splits/<name>/<split>/traj_names.txt, else every trajectory
    splits_dir: str | None = None  # null: <root>/data_splits
    name: str | None = None  # dataset name in data_splits (null: the only one, else the root's name)
    metric_waypoint_spacing: float | None = None  # m; null: <root>/data_config.yaml, else 0.25 (d_step)
    # centre crop before the resize to model.image_size, in training and in the policy:
    # aspect (to image_size's W/H) | official (visualnav-transformer's 4:3) | none
    crop: str = "aspect"
    goal_offset: list[int] = field(default_factory=lambda: [1, 20])  # goal frame offset range (frames ahead)
    end_slack: int = 0  # frames ignored at each trajectory's end
    skip_short: bool = False  # skip (true) or reject (false) trajectories too short for the context
    # waypoint labels: all (poses of frames t+1..t+len_traj_pred, GNM's) | moving (the next len_traj_pred frames where
    # the robot moved: turns in place skipped; a departure, see rvn_il/data/dataset.py)
    waypoint_frames: str = "all"
    # true: also train the first context_size decisions of each trajectory, their context padded with frame 0 as the
    # policy's after reset() (GNM starts at t=context_size; a departure, see rvn_il/data/dataset.py)
    pad_context: bool = False
    # GNM dataset with depth sidecars whose frames (all of them, single frames) only train the depth head, e.g. rvn-gen
    # dataset=negative dataset.save_depth=true on the train scenes: views close to obstacles the expert never has (needs
    # model.depth_aux_weight > 0; a departure, see rvn_il/data/depth_frames.py); null: off
    depth_root: str | None = None
    depth_batch: int = 32  # frames of depth_root per training step
    cache_dir: str | None = None  # packed HDF5 frames; null: <cache root>/packed (top-level cache_dir)
    cache_threads: int = 4  # JPEG decoding threads when building the cache
    num_workers: int = 2  # DataLoader workers
    # expert GNM dataset on other scenes (e.g. rvn-gen split=val): held-out loss and open-loop
    # agreement every train.val_every steps (rvn_il/train/validate.py); null: off
    val_root: str | None = None
    val_split: str = "all"  # data_splits split of val_root to use, or all
    # several GNM datasets at once, e.g. RVN's plus real robot logs (DatasetEntry; the first is the deployment robot's:
    # its spacing and embodiment go into the checkpoint); null: data.root alone. nomad_neg: NoMaD_e's data
    datasets: list[DatasetEntry] | None = None
    # visualnav-transformer's own files, read as data.datasets: a training config (its datasets: block; the train:
    # split folders) and its data_config.yaml (metric_waypoint_spacing per dataset)
    official_config: str | None = None
    official_data_config: str | None = None


@dataclass
class TrainLoopConfig:
    """``train``: optimisation, schedule, checkpoints, validation."""

    max_steps: int | None = None  # null: epochs x steps per epoch
    epochs: int = 100
    batch_size: int | None = None  # null: model.batch_size (of the chosen size)
    lr: float | None = None  # null: model.lr
    ema: bool | None = None  # null: model.ema
    weight_decay: float = 0.01  # AdamW (torch default)
    warmup_frac: float = 0.04  # linear warm-up share of max_steps (official: 4 of 100 epochs)
    warmup_steps: int | None = None  # overrides warmup_frac
    grad_clip: float | None = None  # max gradient norm; null: no clipping
    log_every: int = 10  # TensorBoard scalars (out_dir/tb/<member>)
    ckpt_every: int = 1000
    keep_checkpoints: int = 2
    resume: bool = True  # continue from out_dir's latest checkpoint
    # nomad_neg only: out_dir of a finished nomad_pointgoal run to use as NoMaD_e (not trained
    # again; it saw all expert data, not the paper's 93.75 %)
    expert_from: str | None = None
    # with expert_from: the kept checkpoint of that run to adopt instead of its latest (its model/ckpt_<step>, as
    # rvn-eval's policy.step), to read NoMaD-Neg over NoMaD_e's checkpoints; null: the latest
    expert_step: int | None = None
    tqdm_interval: float = 1.0  # s between progress bar refreshes
    precision: str = "fp32"  # fp32 | bf16: mixed precision with torch.autocast (GPUs with bf16; CPUs run it too)
    # torch.compile of the encoder, Transformer and decoder (rvn_il/models/compiled.py): same losses to float
    # rounding, faster steps after a first one that compiles (minutes on a CPU; kernels cached under the cache root)
    compile: bool = False
    # torch.compile's mode with train.compile: auto | default | reduce-overhead (also replays each compiled part's
    # forward and backward as CUDA graphs on a GPU, for steps bound by the host's launches: NoMaD full x3.3 the plain
    # step on an H200, docs/results/2026-11-27_gpu3; on a CPU it compiles as default). auto: reduce-overhead on one
    # CUDA device, default on a CPU and with several ranks (DDP with CUDA graphs is untested)
    compile_mode: str = "auto"
    val_every: int = 1000  # steps between validations (and at the last step), when data.val_root is set
    val_batches: int = 8  # held-out loss on val_batches x batch_size fixed samples
    val_trajectories: int = 20  # expert trajectories replayed for the open-loop agreement


@dataclass
class TrainAgentConfig:
    """``agent``: the robot the model is trained for. Null: the data's (the embodiment rvn-gen recorded,
    rvn_data/embodiment.py), else `AgentConfig`'s default. A value given here that differs from the data's
    is announced and recorded in the checkpoint (``embodiment.overrides``)."""

    r_robot: float | None = None
    h_robot: float | None = None
    d_step: float | None = None
    theta_step_deg: float | None = None
    allow_sliding: bool | None = None


@dataclass
class TrainConfig:
    """rvn-train: model=vint_pointgoal|nomad_pointgoal|nomad_neg data.root=... out_dir=..."""

    agent: TrainAgentConfig = field(default_factory=TrainAgentConfig)
    model: dict[str, Any] = field(default_factory=dict)  # conf/model/<name>.yaml (its own keys)
    seed: int = 0
    device: str = "auto"  # auto (cuda if available) | cpu | cuda | cuda:1
    out_dir: str = "runs/train/${model.name}"
    # cache root (rvn_data/cache_root.py): null = $RVN_CACHE_DIR, else <out_dir>/cache; the datasets
    # are only read, so they may sit on read-only storage
    cache_dir: str | None = None
    data: DataConfig = field(default_factory=DataConfig)
    train: TrainLoopConfig = field(default_factory=TrainLoopConfig)


def complete_config(cfg: Mapping[str, Any]) -> dict:
    """rvn-train's config as a plain resolved dict with every default filled in and every key
    and type checked against `TrainConfig` (a composed config passes through unchanged)."""
    from omegaconf import OmegaConf

    from rvn_data.config import schema_node

    merged = OmegaConf.merge(schema_node(TrainConfig), OmegaConf.create(dict(cfg)))
    return OmegaConf.to_container(merged, resolve=True)


def register_schema() -> None:
    """Store rvn-train's schema (``base_train``, conf/train.yaml's first default) and the task side's in Hydra's
    ConfigStore; called by rvn-train and by whatever composes the train config (`rvn_il.models.config`)."""
    register_configs()
    register("base_train", TrainConfig)
