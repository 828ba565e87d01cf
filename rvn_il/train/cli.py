"""``rvn-train``: train ViNT-PointGoal, NoMaD-PointGoal or NoMaD-Neg on GNM datasets.

    rvn-train model=nomad_pointgoal data.root=data/expert out_dir=runs/nomad
    rvn-train model=nomad_neg data.root=data/expert data.negative_root=data/negative model.size=small
    torchrun --nproc_per_node=4 -m rvn_il.train.cli model=vint_pointgoal data.root=...

Config: conf/train.yaml and conf/model/*.yaml. Bad input (a path that does not exist, an
unwritable out_dir, a device this machine lacks, a typo'd key) is found before any work and
exits with status 2 and one line, writing nothing; a training that fails exits with status 1.
"""
from __future__ import annotations

import logging
import os
from pathlib import Path
from typing import Sequence

import hydra
from omegaconf import DictConfig, OmegaConf
from rvn_data.config import CONF_DIR, load_config
from rvn_data.cli.common import fail, record_run
from rvn_data.cli.hydra_app import entered_task, run_hydra

from .settings import register_schema

register_schema()

def _run(cfg: DictConfig, record: bool = False) -> Path:
    from .trainer import run_training  # torch with it, after the override check (benchmarks/cli_start.py)

    container = OmegaConf.to_container(cfg, resolve=True)
    container.pop("hydra", None)
    on_checked = (lambda checked: record_run(cfg, Path(checked["out_dir"]).expanduser(), "rvn-train")) if record else None
    return run_training(container, on_checked)


def compose(overrides: Sequence[str] = ()) -> DictConfig:
    """The composed train config for ``overrides`` (for tests and notebooks)."""
    return load_config("train", overrides)


def train(overrides: Sequence[str] = ()) -> Path:
    """Run rvn-train in this process with Hydra-style ``overrides``; returns the out_dir."""
    return _run(compose(overrides))


@hydra.main(config_path=CONF_DIR, config_name="train", version_base="1.3")
def _hydra_main(cfg: DictConfig) -> None:
    entered_task()
    logging.getLogger("rvn_il").setLevel(logging.INFO)
    try:
        out = _run(cfg, record=True)
    except (ValueError, OSError) as e:  # ConfigError (a ValueError): status 2; a failed training: 1
        fail("rvn-train", e)
    if os.environ.get("RANK", "0") == "0":
        print(f"rvn-train: checkpoint in {out}")


def main() -> None:
    run_hydra(_hydra_main, "rvn-train", "train")


if __name__ == "__main__":
    main()
