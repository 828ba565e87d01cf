"""`rvn-gen`: Hydra CLI for trajectory dataset generation (config: conf/gen.yaml).

Bad input (checked before anything is written) ends with a one-line message on stderr and
exit status 2; a run in which some scenes failed lists them in the summary and exits with
status 1, as does a run that fails otherwise (`rvn_data.cli.common`).
"""
from __future__ import annotations

import sys

import hydra
from omegaconf import DictConfig

from rvn_data.cli.common import fail, validating
from rvn_data.cli.hydra_app import entered_task, run_hydra
from rvn_data.config import CONF_DIR, register_configs, typed
from rvn_data.config_schemas import GenConfig

register_configs()


@hydra.main(config_path=CONF_DIR, config_name="gen", version_base="1.3")
def _main(cfg: DictConfig) -> None:
    from dataclasses import replace

    from hydra.core.hydra_config import HydraConfig
    from hydra.utils import to_absolute_path

    entered_task()
    try:
        with validating():
            config = typed(GenConfig, cfg)  # the one conversion: the typed tree goes down from here
        config = replace(config, out_dir=to_absolute_path(config.out_dir))
        from rvn_data.gen.run import generate  # after the settings' checks: its planning chain takes ~0.4 s to import

        status = generate(config, list(HydraConfig.get().overrides.task)).status
    except (ValueError, OSError) as e:  # ConfigError (a ValueError): status 2; a run that failed: 1
        fail("rvn-gen", e)
    if status:
        sys.exit(status)


def main() -> None:
    run_hydra(_main, "rvn-gen", "gen")


if __name__ == "__main__":
    main()
