"""The depth network's settings as one typed tree, `DepthConfig` (conf/rl_depth.yaml names it first,
``base_rl_depth``, and holds only what differs from it): the task side's ``agent``, ``camera``, ``navmesh``,
``renderer`` and ``scenes`` groups, and the depth trainer's own ``pairs``, ``model`` and ``train``. ``python -m rvn_rl.depth.cli``
turns the composed config into it once (`rvn_data.config.typed`: OmegaConf checks keys and types) and each dataclass
checks its own ranges in ``__post_init__`` (one line naming the setting). No torch here: the schema registers
without loading the network. Field order is the order of the config.yaml the command writes."""
from __future__ import annotations

from dataclasses import dataclass, field

from rvn_data.config import register, register_configs
from rvn_data.conventions import AgentConfig
from rvn_data.navmesh.settings import NavMeshSettings
from rvn_data.render import RendererConfig
from rvn_data.render.camera import CameraConfig
from rvn_data.scenes.sets import ScenesConfig

from ..settings import at_least


@dataclass
class PairsSettings:
    """``pairs``: the rendered (RGB, exact depth) pairs (`rvn_rl.depth.pairs`) of the ``scenes`` group's scenes."""

    train_scenes: int = 40  # train-split scenes, from the first
    val_scenes: int = 5  # val-split scenes, from the first
    per_scene: int = 50  # poses per scene
    dir: str | None = None  # where train.h5 / val.h5 live (null: <out_dir>/pairs); reused when settings match

    def __post_init__(self) -> None:
        for key in ("train_scenes", "val_scenes", "per_scene"):
            at_least(f"pairs.{key}", getattr(self, key), 1)


@dataclass
class DepthModelSettings:
    """``model``: `rvn_rl.depth.model.DepthNet`'s arguments."""

    widths: list[int] = field(default_factory=lambda: [16, 32, 64, 96, 128])  # encoder channels, a stride-2 stage each
    min_depth: float = 0.05  # m, output range
    max_depth: float = 20.0

    def __post_init__(self) -> None:  # DepthNet's own rules, checked before any pair is rendered
        if len(self.widths) < 2 or min(self.widths) < 1:
            raise ValueError(f"model.widths={list(self.widths)}: give at least two positive channel counts")
        if not 0.0 < self.min_depth < self.max_depth:
            raise ValueError(f"model.min_depth={self.min_depth}, model.max_depth={self.max_depth} must satisfy "
                             "0 < min < max")


@dataclass
class TrainSettings:
    """``train``: the depth network's optimisation (`rvn_rl.depth.train.train_depth`)."""

    steps: int = 2000
    batch_size: int = 16
    lr: float = 2e-3
    weight_decay: float = 1e-4
    warmup: int = 50
    silog_weight: float = 1.0  # scale-invariant log loss
    l1_weight: float = 1.0  # L1 on log depth (fixes the metric scale)
    variance_focus: float = 0.85
    flip: bool = True
    eval_every: int = 500  # steps between val evaluations (0: only at the end)

    def __post_init__(self) -> None:
        for key, minimum in (("steps", 1), ("batch_size", 1), ("warmup", 0), ("eval_every", 0)):
            at_least(f"train.{key}", getattr(self, key), minimum)
        if not self.lr > 0:
            raise ValueError(f"train.lr={self.lr!r} must be > 0")
        if self.silog_weight < 0 or self.l1_weight <= 0:
            raise ValueError("train.l1_weight must be > 0 (it fixes the metric scale) and train.silog_weight >= 0")


@dataclass
class DepthConfig:
    """python -m rvn_rl.depth.cli out_dir=... pairs.train_scenes=... train.steps=... (conf/rl_depth.yaml)."""

    agent: AgentConfig = field(default_factory=AgentConfig)
    camera: CameraConfig = field(default_factory=CameraConfig)  # conf/rl_depth.yaml: width = height = image_size
    navmesh: NavMeshSettings = field(default_factory=NavMeshSettings)
    renderer: RendererConfig = field(default_factory=RendererConfig)
    # which scenes and how they load (scenes=hm3d: z-up), as rvn-gen's and rvn-rl's; the train and val splits both,
    # pairs.train_scenes and pairs.val_scenes of them from the first (conf/rl_depth.yaml: split train, acting nowhere)
    scenes: ScenesConfig = field(default_factory=lambda: ScenesConfig(split="train"))
    seed: int = 0
    out_dir: str = "runs/rl_depth"
    image_size: int = 128  # square frames, pixels (the RL observation size)
    progress: bool = True
    threads: int | None = None  # torch intra-op threads (null = torch's setting)
    pairs: PairsSettings = field(default_factory=PairsSettings)
    model: DepthModelSettings = field(default_factory=DepthModelSettings)
    train: TrainSettings = field(default_factory=TrainSettings)

    def __post_init__(self) -> None:
        at_least("image_size", self.image_size, 16)
        for key in ("width", "height"):  # conf/rl_depth.yaml sets both to ${image_size}; one given alone would disagree
            value = getattr(self.camera, key)
            if value != self.image_size:
                raise ValueError(f"camera.{key}={value} differs from image_size={self.image_size}: the depth model "
                                 f"trains on image_size pixels square; set image_size={value} (camera.width and "
                                 "height follow it)")
        at_least("seed", self.seed, 0)
        if self.threads is not None:
            at_least("threads", self.threads, 1)
        if not self.out_dir:
            raise ValueError("out_dir is empty; give out_dir=<folder>")
        sc = self.scenes
        for key, value, default, instead in (("split", sc.split, "train", "it renders both the train and val splits"),
                                             ("num_scenes", sc.num_scenes, None, "use pairs.train_scenes and "
                                              "pairs.val_scenes"),
                                             ("first_scene", sc.first_scene, 0, "each split's scenes are taken from "
                                              "the first")):
            if value != default:
                raise ValueError(f"scenes.{key}={value} does nothing in the depth CLI ({instead}); leave scenes.{key} out")
        if sc.up_axis not in ("y", "z"):
            raise ValueError(f"scenes.up_axis={sc.up_axis!r}: choose y or z (HM3D: z)")
        if not sc.unit_scale > 0:
            raise ValueError(f"scenes.unit_scale={sc.unit_scale!r} must be > 0 (metres per mesh unit)")


def register_schema() -> None:
    """Store the depth trainer's schema (``base_rl_depth``, conf/rl_depth.yaml's first default) and the task side's in
    Hydra's ConfigStore; the command calls it before composing."""
    register_configs()
    register("base_rl_depth", DepthConfig)
