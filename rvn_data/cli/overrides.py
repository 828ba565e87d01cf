"""Every command's overrides checked before Hydra runs anything: one line for any config error.

Hydra reports a config error in several lines (and a typo added with ``+``, as its own advice says,
is not an error at all: ``rvn-gen +trajectories_per_scen=4`` ran 10 trajectories per scene). `check`
composes the config exactly as the command will (the same config folder, schemas and overrides;
Hydra's own ``hydra.*`` settings and launcher groups left to Hydra; a sweep ``a=1,2`` or
``range(0,64)`` composes with its first value) and turns every failure into a `ConfigError` of
one line that names the setting:

- a key that is not a setting, with or without ``+``: ``trajectories_per_scen is not a setting of
  rvn-gen; nearest: trajectories_per_scene (rvn-gen --help lists the settings)``. A ``+key`` is
  accepted only inside the command's open groups (`OPEN_GROUPS`: rvn-eval's ``policy``, whose
  keys its policy checks), where the settings are keyword arguments of the chosen class;
- a value of the wrong type: ``camera.width=abc: Value 'abc' of type 'str' could not be converted to Integer``;
- an unknown group option: ``policy=foo is not an option; choose one of checkpoint, goal_follower, ...``.
"""
from __future__ import annotations

import difflib
import re
from typing import Iterable, Sequence

from rvn_data.cli.common import ConfigError, one_line

# Hydra's command-line flags: those that take a value, and those that stop the command (nothing to check)
VALUE_FLAGS = {"--cfg", "-c", "--package", "-p", "--config-path", "-cp", "--config-name", "-cn", "--config-dir", "-cd",
               "--experimental-rerun", "--shell-completion", "-sc"}
STOP_FLAGS = {"-h", "--help", "--hydra-help", "--info", "-i", "--shell-completion", "-sc", "--version"}
OPEN_GROUPS = {"eval": ("policy",)}  # config name -> groups whose keys the chosen class checks (its kwargs)
PATH_KEYS = ("out_dir", "_dir", "root", "_path", "_from")  # settings that name a folder or file: never empty


def overrides_of(argv: Sequence[str]) -> list[str] | None:
    """The override arguments of a Hydra command line; None when a flag (``--help``) stops it."""
    out, skip = [], False
    for arg in argv:
        if skip:
            skip = False
            continue
        if arg in STOP_FLAGS:
            return None
        if arg in VALUE_FLAGS:
            skip = True
            continue
        if arg.startswith("-"):
            continue  # -m / --multirun / --resolve / --run
        out.append(arg)
    return out


def first_values(overrides: list[str]) -> list[str]:
    """The overrides one job of a sweep composes: ``a=1,2`` -> ``a=1``, ``i=range(0,64)`` -> ``i=0``; ``hydra.*`` left out."""
    return _first_values(overrides)[0]


def _first_values(overrides: list[str]) -> tuple[list[str], list]:
    """(overrides as compose() takes them: no hydra settings, sweeps at their first value, parsed overrides)."""
    from hydra.core.override_parser.overrides_parser import OverridesParser
    from hydra.errors import HydraException

    parser = OverridesParser.create()
    composed, parsed = [], []
    for text in overrides:
        try:
            ov = parser.parse_override(text)
        except HydraException as err:
            raise ConfigError(f"cannot read the override {text!r} ({one_line(err)}); write key=value") from None
        key = ov.get_key_element().lstrip("+~")
        if key == "hydra" or key.startswith(("hydra.", "hydra/")):
            continue
        if ov.is_sweep_override():
            first = next(iter(ov.sweep_string_iterator()), None)
            text = f"{ov.get_key_element()}={first}" if first is not None else text
        composed.append(text)
        parsed.append(ov)
    return composed, parsed


def _compose(config_dir: str, config_name: str, overrides: list[str]):
    from hydra import compose, initialize_config_dir
    from hydra.core.global_hydra import GlobalHydra

    if GlobalHydra.instance().is_initialized():
        GlobalHydra.instance().clear()
    with initialize_config_dir(config_dir=config_dir, version_base="1.3"):
        return compose(config_name=config_name, overrides=overrides)


def _dotted_keys(node, prefix: str = "") -> list[str]:
    from omegaconf import DictConfig

    out = []
    if isinstance(node, DictConfig):
        for key in node.keys():
            full = f"{prefix}{key}"
            out.append(full)
            child = node._get_node(key)
            if isinstance(child, DictConfig):
                out += _dotted_keys(child, full + ".")
    return out


def nearest(key: str, cfg, prog: str) -> str:
    """``<key> is not a setting of <prog>; nearest: a, b (<prog> --help lists the settings)``."""
    keys = [k for k in _dotted_keys(cfg) if not k.startswith("hydra")]
    parent, _, leaf = key.rpartition(".")
    siblings = [k for k in keys if k.rpartition(".")[0] == parent]
    close = difflib.get_close_matches(key, siblings, n=3, cutoff=0.6) or difflib.get_close_matches(key, keys, n=3, cutoff=0.6)
    if not close:  # the leaf alone, anywhere (train.max_step -> train.max_steps; total_step -> train.total_steps)
        close = [k for k in keys if difflib.get_close_matches(leaf, [k.rpartition(".")[2]], n=1, cutoff=0.75)][:3]
    hint = f"nearest: {', '.join(close)}" if close else f"settings under {parent or 'the top'}: " + ", ".join(
        k.rpartition(".")[2] for k in siblings[:12])
    return f"{key} is not a setting of {prog}; {hint} ({prog} --help lists the settings)"


def _explain(err: BaseException, prog: str, config_dir: str, config_name: str, composed: list[str]) -> str:
    """One line for a composition error."""
    from hydra.errors import MissingConfigException

    if isinstance(err, MissingConfigException):
        group = (err.missing_cfg_file or "").rpartition("/")[0]
        value = (err.missing_cfg_file or "").rpartition("/")[2]
        options = ", ".join(o for o in err.options or [] if not o.startswith("base_"))  # base_*: schemas
        if group and options:
            return f"{group}={value} is not an option; choose one of {options}"
        return one_line(err)
    cause = err.__cause__ or err
    text = str(err)
    m = re.search(r"Could not override '([^']+)'", text) or re.search(r"Key '([^']+)' (?:is not in struct|not in)", text)
    if m and ("not in struct" in text or "ConfigKeyError" in type(cause).__name__ or "not in" in str(cause)):
        base = [o for o in composed if not o.split("=", 1)[0].lstrip("+~").startswith(m.group(1))]
        try:
            cfg = _compose(config_dir, config_name, base)
        except Exception:  # noqa: BLE001 - a second problem: name the first one plainly
            return f"{m.group(1)} is not a setting of {prog} ({prog} --help lists the settings)"
        return nearest(m.group(1), cfg, prog)
    key = getattr(cause, "full_key", None) or getattr(err, "full_key", None)
    msg = one_line(cause)
    if key:
        given = next((o.split("=", 1)[1] for o in reversed(composed) if o.split("=", 1)[0].lstrip("+~") == key), None)  # the last wins
        return f"{key}={given}: {msg}" if given is not None else f"{key}: {msg}"
    return msg


def _untyped(cfg, key: str) -> bool:
    """Whether the composed setting ``key`` has no type of its own (a key of a group without a schema, as rvn-eval's
    ``policy``): composition took any value there. A schema's typed settings were converted or refused already."""
    from omegaconf import AnyNode, DictConfig, OmegaConf

    parent, _, leaf = key.rpartition(".")
    try:
        node = OmegaConf.select(cfg, parent, throw_on_missing=False) if parent else cfg
        child = node._get_node(leaf) if isinstance(node, DictConfig) else None
    except Exception:  # noqa: BLE001 - not a plain setting: compare it as before
        return True
    return child is None or isinstance(child, AnyNode)


def _check_types(cfg, parsed: list, config_dir: str, config_name: str, composed: list[str]) -> None:
    """Settings without a schema (rvn-eval's ``policy`` group: keyword arguments of the chosen class) take any value
    at composition: a number or a boolean given as text (``policy.turn_cost=abc``) is refused here, against the type
    of the setting's default."""
    from omegaconf import OmegaConf

    given = {ov.get_key_element(): ov for ov in parsed if "/" not in ov.get_key_element()
             and not ov.get_key_element().startswith(("+", "~")) and "." in ov.get_key_element()}
    given = {key: ov for key, ov in given.items() if _untyped(cfg, key)}  # a schema's types checked at composition
    if not given:  # nothing to compare: spare the second composition (a quarter of a second)
        return
    defaults = _compose(config_dir, config_name, [o for o in composed if "." not in o.split("=", 1)[0]])
    for key, ov in given.items():
        default = OmegaConf.select(defaults, key, default=None, throw_on_missing=False)
        value = OmegaConf.select(cfg, key, default=None, throw_on_missing=False)
        if value is None:  # null: the setting's "none" (num_scenes=null: every scene)
            continue
        if isinstance(default, bool):
            ok = isinstance(value, bool)
        elif isinstance(default, (int, float)):
            ok = isinstance(value, (int, float)) and not isinstance(value, bool)
        else:
            continue
        if not ok:
            kind = "true or false" if isinstance(default, bool) else "a number"
            raise ConfigError(f"{key}={ov.value()!r}: give {kind} (default {default!r})")


def check(prog: str, config_name: str, config_dir: str, argv: Sequence[str],
          open_groups: Iterable[str] | None = None) -> None:
    """Compose ``config_name`` with the overrides of ``argv`` as the command will; `ConfigError` (one line)
    on any config error or on a ``+key`` that adds a setting the config does not have (outside ``open_groups``,
    by default `OPEN_GROUPS` of the config)."""
    from omegaconf import OmegaConf

    overrides = overrides_of(argv)
    if overrides is None:
        return
    composed, parsed = _first_values(overrides)
    sweeps = [ov.input_line for ov in parsed if ov.is_sweep_override()]
    if sweeps and not {"-m", "--multirun"} & set(argv):
        raise ConfigError(f"{sweeps[0]} is a sweep (several values): add -m to run one job per value, or give one value")
    try:
        cfg = _compose(config_dir, config_name, composed)
    except Exception as err:  # noqa: BLE001 - Hydra and OmegaConf raise many types; each becomes one line
        raise ConfigError(_explain(err, prog, config_dir, config_name, composed)) from None
    _check_types(cfg, parsed, config_dir, config_name, composed)
    for ov in parsed:  # out_dir= (empty) would write into the current folder
        key = ov.get_key_element().lstrip("+~")
        if key.endswith(PATH_KEYS) and OmegaConf.select(cfg, key, default=None, throw_on_missing=False) == "":
            raise ConfigError(f"{key}= is empty: give a folder or file, or leave {key} out for its default")
    open_groups = tuple(OPEN_GROUPS.get(config_name, ()) if open_groups is None else open_groups)
    added = [ov for ov in parsed if ov.get_key_element().startswith("+") and not ov.get_key_element().startswith("++")
             and "/" not in ov.get_key_element()]
    if not added:
        return
    keys = {ov.get_key_element().lstrip("+") for ov in added}
    keys = {key for key in keys if key.split(".")[0] not in open_groups}  # the chosen class checks its own
    if not keys:
        return
    base = [o for o in composed if o.split("=", 1)[0].lstrip("+") not in keys or o.startswith("++")]
    try:
        base_cfg = _compose(config_dir, config_name, base)
    except Exception:  # noqa: BLE001 - the full composition worked; judge against it
        base_cfg = cfg
    for key in sorted(keys):
        if OmegaConf.select(base_cfg, key, default="__missing__", throw_on_missing=False) == "__missing__":
            raise ConfigError(nearest(key, base_cfg, prog))
