"""Starting an RVN command that is a Hydra app (rvn-gen, rvn-train, rvn-eval, rvn-rl): `run_hydra` checks the
command line's overrides first (`rvn_data.cli.overrides.check`: one line and `BAD_INPUT` for a config error), then
runs the ``@hydra.main`` function, whose own failures before the command is entered (`entered_task`) are bad input too.
The exit-status convention is `rvn_data.cli.common`'s."""
from __future__ import annotations

import sys
from typing import Callable

from rvn_data.cli.common import BAD_INPUT, ConfigError, fail
from rvn_data.cli.overrides import check
from rvn_data.config import CONF_DIR

_entered: dict = {"task": False}


def entered_task() -> None:
    """Note that Hydra composed the config and called the command (see `run_hydra`)."""
    _entered["task"] = True


def run_hydra(hydra_main: Callable[[], None], prog: str | None = None, config_name: str | None = None,
              config_dir: str | None = None) -> None:
    """Call a ``@hydra.main`` function. With ``prog`` and ``config_name``, the command line's overrides
    are first composed as the command will (`rvn_data.cli.overrides.check`): a typo'd key (with or
    without ``+``), a value of the wrong type or an unknown group option ends in one line naming the
    setting and `BAD_INPUT`, before Hydra starts. Whatever Hydra itself still reports with status 1
    before the command is called is bad input too, so it exits with `BAD_INPUT` like the command's own."""
    if prog is not None and config_name is not None:
        try:
            check(prog, config_name, config_dir or CONF_DIR, sys.argv[1:])
        except ConfigError as err:
            fail(prog, err)
    try:
        hydra_main()
    except SystemExit as exc:
        if exc.code == 1 and not _entered["task"]:
            sys.exit(BAD_INPUT)
        raise


__all__ = ["entered_task", "run_hydra"]
