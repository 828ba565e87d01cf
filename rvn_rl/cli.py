"""``rvn-rl``: train an RL baseline on RVN-v0. Hydra config ``conf/rl.yaml`` with the groups
``algo`` (conf/rl/algo: ppo, ppo_lag, ddppo, ddppo_depth) and ``scale`` (conf/rl/scale:
small, paper). DD-PPO: ``torchrun --nproc_per_node=N -m rvn_rl.cli algo=ddppo ...``."""
from __future__ import annotations

import json
import sys
from pathlib import Path

import hydra
from hydra.core.config_store import ConfigStore
from omegaconf import DictConfig, OmegaConf
from omegaconf.errors import OmegaConfBaseException

from .config import CONF_RL

CONF_DIR = str(CONF_RL.parent)
GROUPS = {"algo": "algo", "scale": "_global_"}


def register_groups() -> None:
    """conf/rl/<group>/<name>.yaml as Hydra group options ``<group>=<name>``."""
    cs = ConfigStore.instance()
    for group, package in GROUPS.items():
        for path in sorted((CONF_RL / group).glob("*.yaml")):
            cs.store(group=group, name=path.stem, node=OmegaConf.load(path), package=package)


def check_choices(argv: list[str]) -> None:
    """One-line errors for an unknown ``algo=`` / ``scale=`` before Hydra's multi-line ones."""
    for arg in argv:
        key, _, value = arg.partition("=")
        if key in GROUPS:
            names = sorted(p.stem for p in (CONF_RL / key).glob("*.yaml"))
            if value not in names:
                print(f"rvn-rl: error: {key}={value!r} is unknown; choose one of {', '.join(names)}", file=sys.stderr)
                sys.exit(1)


def compose(overrides: list[str] = ()) -> dict:
    """The resolved rvn-rl config for ``overrides`` (as on the command line), without running."""
    from hydra import compose as hydra_compose, initialize_config_dir

    check_choices(list(overrides))
    _register_task_schemas()
    register_groups()
    with initialize_config_dir(config_dir=CONF_DIR, version_base="1.3"):
        cfg = hydra_compose(config_name="rl", overrides=list(overrides))
    return OmegaConf.to_container(cfg, resolve=True, throw_on_missing=True)


def run(cfg: dict) -> dict:
    from .trainer import train

    return train(cfg)


@hydra.main(config_path=CONF_DIR, config_name="rl", version_base="1.3")
def _main(cfg: DictConfig) -> None:
    from rvn_data.scenes import SceneError

    try:
        plain = OmegaConf.to_container(cfg, resolve=True, throw_on_missing=True)
        result = run(plain)
    except (ValueError, TypeError, SceneError, OSError, OmegaConfBaseException) as err:
        msg = (str(err).splitlines() or [type(err).__name__])[0]
        print(f"rvn-rl: error: {msg}", file=sys.stderr)
        sys.exit(1)
    if "summary" in result:
        print(result.pop("summary"))
        print(json.dumps({k: v for k, v in result.items() if isinstance(v, (int, float))}))
        print(f"wrote {Path(plain['out_dir']) / 'config.yaml'}")


def _register_task_schemas() -> None:
    """The task side's structured config schemas (base_camera, base_scenes, ...), when this
    tree's conf/ uses them."""
    try:
        from rvn_data.config import register_configs
    except ImportError:
        return
    register_configs()


def main() -> None:
    check_choices(sys.argv[1:])
    _register_task_schemas()
    register_groups()
    _main()


if __name__ == "__main__":
    main()
