"""`rvn-gen`: Hydra CLI for trajectory dataset generation (config: conf/gen.yaml).

Bad input ends with a one-line message on stderr and a non-zero exit status; a run in
which some scenes failed lists them in the summary and exits with status 1.
"""
from __future__ import annotations

import sys

import hydra
from omegaconf import DictConfig, OmegaConf

from rvn_data.config import CONF_DIR, register_configs

register_configs()


@hydra.main(config_path=CONF_DIR, config_name="gen", version_base="1.3")
def _main(cfg: DictConfig) -> None:
    from hydra.utils import to_absolute_path

    from rvn_data.gen.run import generate

    container = OmegaConf.to_container(cfg, resolve=True)
    container["out_dir"] = to_absolute_path(container["out_dir"])
    try:
        status = generate(container).status
    except (ValueError, OSError) as e:  # SceneError is a ValueError
        print(f"rvn-gen: error: {e}", file=sys.stderr)
        sys.exit(2)
    if status:
        sys.exit(status)


def main() -> None:
    _main()


if __name__ == "__main__":
    main()
