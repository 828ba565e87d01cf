"""What RVN's commands share about failing and about recording a run (rvn-gen, rvn-train, rvn-eval
and rvn-rl are Hydra apps, started by `rvn_data.cli.hydra_app.run_hydra`; rvn-scene and the
``python -m`` tools use argparse).

One exit-status convention for every RVN tool:

- ``BAD_INPUT`` (2): bad input or config, found before any work: a typo'd key, a path that does
  not exist, an out_dir that cannot be written, a device this machine lacks. One line on stderr,
  and nothing is written (no out_dir, no ``.hydra/``, no log);
- ``RUN_FAILED`` (1): the run started and failed (a scene that failed, a non-finite loss, a full disk).

The commands' Hydra configs leave ``hydra.run.dir`` at ``.`` with ``output_subdir: null`` and
log to the console only, so Hydra creates nothing before the command has checked its settings;
`record_run` then writes Hydra's record (``out_dir/.hydra/``) and the log file itself.

    with validating():                 # any ValueError / OSError in here is bad input (exit 2)
        check_writable_dir(cfg["out_dir"])
    record_run(cfg, out_dir, "rvn-eval")
"""
from __future__ import annotations

import logging
import os
import sys
import threading
from contextlib import contextmanager
from pathlib import Path
from typing import Iterator, NoReturn

BAD_INPUT = 2
RUN_FAILED = 1
LOG_FORMAT = "[%(asctime)s][%(name)s][%(levelname)s] - %(message)s"  # Hydra's default job_logging format

_log: dict = {"handler": None}  # the log file handler `record_run` added last


class ConfigError(ValueError):
    """Bad input or config found before any work (exit status `BAD_INPUT`)."""


def one_line(err: BaseException) -> str:
    """The first non-empty line of an error's message (its type's name when it has none)."""
    lines = [ln.strip() for ln in str(err).splitlines() if ln.strip()]
    return lines[0] if lines else type(err).__name__


@contextmanager
def validating() -> Iterator[None]:
    """Turn a ValueError, TypeError or OSError raised inside into a `ConfigError` (one line)."""
    try:
        yield
    except ConfigError:
        raise
    except (ValueError, TypeError, OSError) as err:
        raise ConfigError(one_line(err)) from err


def check_writable_dir(path: str | Path, key: str = "out_dir=") -> Path:
    """The absolute ``path``; `ConfigError` naming the setting ``key`` (``out_dir=``, ``-o ``)
    unless it is (or can be made) a folder this process can write to: a file is written and removed in the folder,
    or, where it does not exist yet, in its nearest existing parent (who may add an entry there may make the folders
    below). It makes and removes no folder: removing folders made to find out raced another run making its real
    folder inside one of them (two runs started into one new parent folder: the other's mkdir failed with "No such
    file or directory")."""
    path = Path(path).expanduser().absolute()
    if path.exists() and not path.is_dir():
        raise ConfigError(f"{key}{path} is a file, not a folder; choose a folder for {key.strip()}")
    p = path
    while not p.exists() and p != p.parent:
        p = p.parent
    probe = p / f".rvn_write_probe_{os.getpid()}_{threading.get_ident()}"
    try:
        if not p.is_dir():
            raise NotADirectoryError(20, f"{p} is a file, not a folder")
        probe.write_bytes(b"")
        probe.unlink()
    except OSError as err:
        raise ConfigError(f"{key}{path}: cannot write there ({err.strerror or err}); "
                          f"choose a writable {key.strip()}") from None
    return path


def record_run(cfg, out_dir: str | Path, tool: str) -> None:
    """After validation: Hydra's record of this run (``out_dir/.hydra/config.yaml``,
    ``hydra.yaml``, ``overrides.yaml``) and the log file ``out_dir/<tool>.log`` (appended to).
    Only rank 0 of a torchrun job writes them; outside a Hydra app, nothing."""
    from hydra.core.hydra_config import HydraConfig
    from omegaconf import OmegaConf

    if not HydraConfig.initialized() or os.environ.get("RANK", "0") != "0":
        return
    out_dir = Path(out_dir)
    record = out_dir / ".hydra"
    record.mkdir(parents=True, exist_ok=True)
    hydra_cfg = HydraConfig.get()
    (record / "config.yaml").write_text(OmegaConf.to_yaml(cfg))
    (record / "hydra.yaml").write_text(OmegaConf.to_yaml(OmegaConf.create({"hydra": hydra_cfg})))
    (record / "overrides.yaml").write_text(OmegaConf.to_yaml(OmegaConf.create(list(hydra_cfg.overrides.task))))
    root = logging.getLogger()
    if _log["handler"] is not None:  # an earlier run in this process (tests, multirun): its file no more
        root.removeHandler(_log["handler"])
        _log["handler"].close()
    handler = logging.FileHandler(out_dir / f"{tool}.log")
    handler.setFormatter(logging.Formatter(LOG_FORMAT))
    root.addHandler(handler)
    _log["handler"] = handler


def fail(prog: str, err: BaseException, code: int | None = None) -> NoReturn:
    """One line on stderr, then exit: `BAD_INPUT` for a `ConfigError`, else `RUN_FAILED`."""
    print(f"{prog}: error: {one_line(err)}", file=sys.stderr)
    sys.exit(code if code is not None else BAD_INPUT if isinstance(err, ConfigError) else RUN_FAILED)


__all__ = ["BAD_INPUT", "RUN_FAILED", "ConfigError", "check_writable_dir", "fail", "one_line", "record_run",
           "validating"]
