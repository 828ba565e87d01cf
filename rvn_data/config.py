"""The commands' configs: where they live (`CONF_DIR`), their typed schemas, one way to load them.

Every setting has its default in one place, the dataclass that uses it; `register_configs`
stores those dataclasses in Hydra's ConfigStore (structured configs), and each YAML file
under ``conf/`` names its schema first in its defaults list (``defaults: [base_camera,
_self_]``) and holds only what differs from it. Composition checks every key and type, so
a typo'd key or a value of the wrong type stops rvn-gen / rvn-eval / rvn-train at start-up
with Hydra's own message.

Schemas: groups ``agent`` (`AgentConfig`), ``camera`` (`CameraConfig`), ``navmesh``
(`NavMeshSettings`), ``dataset`` (`DatasetConfig`), ``renderer`` (`RendererConfig`),
``scenes`` (`ScenesConfig`); primary configs ``gen`` (`GenConfig`) and ``eval``
(`EvalConfig`) here, ``train`` in `rvn_il.train.settings` and ``rl`` in `rvn_rl.config` (each its
``register_schema``, which rvn-train / rvn-rl call; the task side never imports the IL or RL side).

    cfg = load_config("eval", overrides=["policy=random", "episodes.per_scene=2"])
"""
from __future__ import annotations

from pathlib import Path
from typing import Sequence

CONF_DIR = str(Path(__file__).resolve().parents[1] / "conf")

_registered: set[str] = set()


def schema_node(cls: type):
    """A dataclass as a writable OmegaConf node (frozen dataclasses give read-only ones,
    which Hydra could not merge the YAML values into)."""
    from omegaconf import OmegaConf

    node = OmegaConf.structured(cls)
    _writable(node)
    return node


def _writable(node) -> None:
    from omegaconf import DictConfig, OmegaConf

    OmegaConf.set_readonly(node, None)
    if isinstance(node, DictConfig):
        for key in node:
            _writable(node._get_node(key))


def register(name: str, cls: type, group: str | None = None) -> None:
    """Store ``cls`` in Hydra's ConfigStore as ``[group/]name`` (once per process)."""
    from hydra.core.config_store import ConfigStore

    key = f"{group}/{name}" if group else name
    if key not in _registered:
        ConfigStore.instance().store(group=group, name=name, node=schema_node(cls))
        _registered.add(key)


def typed(cls: type, cfg):
    """A command's typed settings tree: an instance of the schema ``cls`` from its composed config
    (a DictConfig) or from a plain, possibly partial mapping merged over the schema's defaults.
    OmegaConf checks keys and types (an unknown key or a value of the wrong type is a ValueError
    naming it); each dataclass's ``__post_init__`` checks its ranges. The one conversion a command makes."""
    from omegaconf import OmegaConf
    from omegaconf.errors import InterpolationResolutionError, MissingMandatoryValue, OmegaConfBaseException

    if isinstance(cfg, cls):
        return cfg
    try:
        return OmegaConf.to_object(OmegaConf.merge(schema_node(cls), cfg))
    except OmegaConfBaseException as err:
        first = (str(err).strip().splitlines() or [type(err).__name__])[0]
        key = getattr(err, "full_key", None)
        if key and isinstance(err, (MissingMandatoryValue, InterpolationResolutionError)):  # policy.checkpoint_path=???
            first += f" (config key {key}: set it on the command line, e.g. {key}=...)"
        elif key:
            first += f" (config key {key})"
        raise ValueError(first) from None


def register_configs() -> None:
    """Register the task side's schemas (idempotent)."""
    from rvn_data.config_schemas import EvalConfig, GenConfig
    from rvn_data.conventions import AgentConfig
    from rvn_data.dataset.settings import DatasetConfig
    from rvn_data.navmesh.settings import NavMeshSettings
    from rvn_data.render import RendererConfig
    from rvn_data.render.camera import CameraConfig
    from rvn_data.scenes.sets import ScenesConfig

    for group, name, cls in (("agent", "base_agent", AgentConfig), ("camera", "base_camera", CameraConfig),
                             ("navmesh", "base_navmesh", NavMeshSettings), ("dataset", "base_dataset", DatasetConfig),
                             ("renderer", "base_renderer", RendererConfig), ("scenes", "base_scenes", ScenesConfig),
                             (None, "base_gen", GenConfig), (None, "base_eval", EvalConfig)):
        register(name, cls, group)
    _register_resolvers()


def eval_run_name(method: str | None, policy: str | None, checkpoint_path: str | None = None,
                  first_scene: int | None = 0, step: int | None = None, env_steps: int | None = None) -> str:
    """rvn-eval's default out_dir leaf (``${rvn_eval_name:...}`` in `EvalConfig.out_dir`): the
    method label, else the checkpoint folder's name (`checkpoint_label`: with ``_ckpt<n>`` for a kept checkpoint
    other than the latest, ``policy.step`` or ``policy.env_steps``), else the policy config's name; so two
    models' evaluations land in two folders (runs/eval/val/NoMaD-Neg, runs/eval/val/nomad). A shard that starts
    at another scene than the first (``episodes.first_scene``, e.g. a multirun over ``range(0,50,5)``) gets
    ``_first_scene<N>``, so the shards do not write into one folder (the report merges them)."""
    name = method or checkpoint_label(checkpoint_path, step, env_steps) or policy or "policy"
    name = "_".join(str(name).replace("/", "_").replace("\\", "_").split()) or "policy"
    return f"{name}_first_scene{first_scene}" if first_scene else name


def checkpoint_label(checkpoint_path: str | None, step: int | None = None, env_steps: int | None = None,
                     resolve: bool = False) -> str | None:
    """A checkpoint's row label when method= is not given: its folder's name, and ``" ckpt<n>"`` for a kept
    checkpoint other than the latest (``policy.step`` of rvn-train's, ``policy.env_steps`` of rvn-rl's), the label
    the report reads a row over its checkpoints by ("nomad" and "nomad ckpt9000"). None without a checkpoint."""
    if not checkpoint_path:
        return None
    path = Path(str(checkpoint_path)).expanduser()
    name = (path.resolve() if resolve else path).name
    at = step if step is not None else env_steps
    return name if at is None else f"{name} ckpt{at}"


def _register_resolvers() -> None:
    from omegaconf import OmegaConf

    if not OmegaConf.has_resolver("rvn_eval_name"):
        OmegaConf.register_new_resolver("rvn_eval_name", eval_run_name)


def load_config(name: str, overrides: Sequence[str] = ()):
    """The composed config ``conf/<name>.yaml`` with Hydra-style ``overrides`` (DictConfig,
    interpolations unresolved). Inside a running Hydra app (which already searches CONF_DIR)
    it composes with that app's loader."""
    from hydra import compose, initialize_config_dir
    from hydra.core.global_hydra import GlobalHydra

    register_configs()
    if GlobalHydra.instance().is_initialized():
        return compose(config_name=name, overrides=list(overrides))
    with initialize_config_dir(config_dir=CONF_DIR, version_base="1.3"):
        return compose(config_name=name, overrides=list(overrides))


__all__ = ["CONF_DIR", "eval_run_name", "load_config",
           "register", "register_configs", "schema_node", "typed"]
