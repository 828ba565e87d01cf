"""``rvn-train``: train ViNT-PointGoal, NoMaD-PointGoal or NoMaD-Neg on GNM datasets.

    rvn-train model=nomad_pointgoal data.root=data/expert out_dir=runs/nomad
    rvn-train model=nomad_neg data.root=data/expert data.negative_root=data/negative model.size=small
    torchrun --nproc_per_node=4 -m rvn_il.train.cli model=vint_pointgoal data.root=...

Config: conf/train.yaml and conf/model/*.yaml. Bad input exits with status 1 and one line.
"""
from __future__ import annotations

import logging
import os
import sys
from pathlib import Path
from typing import Sequence

import hydra
from omegaconf import DictConfig, OmegaConf
from rvn_data.config import CONF_DIR, load_config, register_configs

from . import settings  # noqa: F401  (registers conf/train.yaml's schema, base_train)
from .trainer import run_training

register_configs()

def _run(cfg: DictConfig) -> Path:
    container = OmegaConf.to_container(cfg, resolve=True)
    container.pop("hydra", None)
    return run_training(container)


def compose(overrides: Sequence[str] = ()) -> DictConfig:
    """The composed train config for ``overrides`` (for tests and notebooks)."""
    return load_config("train", overrides)


def train(overrides: Sequence[str] = ()) -> Path:
    """Run rvn-train in this process with Hydra-style ``overrides``; returns the out_dir."""
    return _run(compose(overrides))


@hydra.main(config_path=CONF_DIR, config_name="train", version_base="1.3")
def _hydra_main(cfg: DictConfig) -> None:
    logging.getLogger("rvn_il").setLevel(logging.INFO)
    try:
        out = _run(cfg)
    except (ValueError, OSError) as e:
        print(f"rvn-train: error: {e}", file=sys.stderr)
        sys.exit(1)
    if os.environ.get("RANK", "0") == "0":
        print(f"rvn-train: checkpoint in {out}")


def main() -> None:
    _hydra_main()


if __name__ == "__main__":
    main()
