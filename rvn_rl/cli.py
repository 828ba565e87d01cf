"""``rvn-rl``: train an RL baseline on RVN-v0. Hydra config ``conf/rl.yaml`` with the groups
``algo`` (conf/rl/algo: ppo, ppo_lag, ddppo, ddppo_depth) and ``scale`` (conf/rl/scale:
small, paper); the settings' schema is `rvn_rl.config.RLConfig` (``base_rl``, registered by `register_schema`),
into which Hydra's config is turned once. DD-PPO: ``torchrun --nproc_per_node=N -m rvn_rl.cli algo=ddppo ...``.
Bad input exits with status 2 and one line, writing nothing; a failed run with status 1
(`rvn_data.cli.common`)."""
from __future__ import annotations

import json
import sys
from pathlib import Path

import hydra
from hydra.core.config_store import ConfigStore
from omegaconf import DictConfig, OmegaConf

from .config import RLConfig, register_schema, settings_of, world_size_from_env
from .settings import CONF_RL

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
                sys.exit(2)


def compose(overrides: list[str] = ()) -> RLConfig:
    """The rvn-rl settings for ``overrides`` (as on the command line), without running."""
    from hydra import compose as hydra_compose, initialize_config_dir

    check_choices(list(overrides))
    register_schema()
    register_groups()
    with initialize_config_dir(config_dir=CONF_DIR, version_base="1.3"):
        cfg = hydra_compose(config_name="rl", overrides=list(overrides))
    return settings_of(cfg)


def run(cfg: RLConfig, on_checked=None) -> dict:
    from .trainer import train

    return train(cfg, on_checked)


@hydra.main(config_path=CONF_DIR, config_name="rl", version_base="1.3")
def _main(cfg: DictConfig) -> None:
    from rvn_data.cli.common import ConfigError, fail, record_run, validating
    from rvn_data.cli.hydra_app import entered_task

    entered_task()
    try:
        settings = settings_of(cfg)
        with validating():  # every settings rule before torch loads (benchmarks/cli_start.py)
            settings.validate(world_size_from_env())
    except ConfigError as err:
        fail("rvn-rl", err)
    from rvn_data.warning_lines import said_once

    try:
        with said_once("rvn-rl"):  # a scene's warnings in one line, once for the run, its env workers and helpers
            result = run(settings, lambda: record_run(cfg, Path(settings.out_dir).expanduser(), "rvn-rl"))
    except (ValueError, TypeError, OSError) as err:  # SceneError is a ValueError; ConfigError: status 2
        fail("rvn-rl", err)
    if "finished" in result:  # nothing trained, nothing written
        print(result["finished"])
    elif "summary" in result:
        print(result.pop("summary"))
        print(json.dumps({k: v for k, v in result.items() if isinstance(v, (int, float))}))
        print(f"wrote {Path(settings.out_dir) / 'config.yaml'}")


def main() -> None:
    from rvn_data.cli.hydra_app import run_hydra

    check_choices(sys.argv[1:])
    register_schema()
    register_groups()
    run_hydra(_main, "rvn-rl", "rl", CONF_DIR)


if __name__ == "__main__":
    main()
