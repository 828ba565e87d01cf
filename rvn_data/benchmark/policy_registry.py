"""Which object a policy config builds: the policies installed packages register under the entry point
group ``rvn.policies`` (pyproject.toml ``[project.entry-points."rvn.policies"]``, ``name = "module:attr"``).

A policy config (``conf/policy/<name>.yaml``) keeps its ``_target_``, a dotted path: it is part of every
finished run's identity (run.json), so it never changes. rvn-eval resolves it to the registered entry point
whose value names the same object (``module:attr`` == the dotted ``_target_``) and loads that; the task side
imports no model code of its own accord. A ``_target_`` no package registers (a quick policy of one's own on
PYTHONPATH) is still imported by its dotted path, and rvn-eval says it is not registered (`unregistered_note`).
"""
from __future__ import annotations

import pkgutil
from collections.abc import Callable
from importlib.metadata import EntryPoint
from pathlib import Path

POLICIES_GROUP = "rvn.policies"  # package entry points: policy name -> its class or factory


def registered_policies() -> dict[str, EntryPoint]:
    """The policies installed packages register (entry point group ``rvn.policies``), by name."""
    from importlib.metadata import entry_points

    return {ep.name: ep for ep in entry_points(group=POLICIES_GROUP)}


def dotted(ep: EntryPoint) -> str:
    """An entry point's value ``module:attr`` as the dotted path a ``_target_`` writes."""
    return f"{ep.module}.{ep.attr}" if ep.attr else ep.module


def registered_name(target: str, registered: dict[str, EntryPoint] | None = None) -> str | None:
    """The name of the registered policy whose entry point names ``target``'s object; None when none does."""
    registered = registered_policies() if registered is None else registered
    return next((name for name, ep in sorted(registered.items()) if dotted(ep) == target), None)


def own_policy_targets() -> dict[str, str]:
    """``_target_`` -> name of RVN's own policy configs (conf/policy/<name>.yaml): every one is registered."""
    import yaml

    from rvn_data.config import CONF_DIR

    out = {}
    for path in sorted(Path(CONF_DIR, "policy").glob("*.yaml")):
        cfg = yaml.safe_load(path.read_text())
        if isinstance(cfg, dict) and isinstance(cfg.get("_target_"), str):
            out[cfg["_target_"]] = path.stem
    return out


def policy_factory(target) -> tuple[Callable, str | None]:
    """The class or factory a policy config's ``_target_`` names and the name it is registered under (None: not
    registered, imported by its dotted path). A ValueError in one line when it cannot be imported (naming the
    registered policies), or when it is one of RVN's own policy configs' targets and the installed metadata does not
    register it (a stale ``pip install -e .``)."""
    registered = registered_policies()
    if target is None:
        raise ValueError(f"the policy config has no _target_; {_choices(registered)}")
    if not isinstance(target, str):
        raise ValueError(f"policy._target_={target!r} is not a dotted path to a policy; {_choices(registered)}")
    name = registered_name(target, registered)
    if name is None:
        conf = own_policy_targets().get(target)
        if conf is not None:
            raise ValueError(f"policy._target_={target} (conf/policy/{conf}.yaml) is not registered in the installed "
                             f"package metadata (entry points {POLICIES_GROUP}: {', '.join(sorted(registered)) or 'none'});"
                             " it predates this checkout: run pip install -e . in RVN's checkout")
    try:
        factory = registered[name].load() if name is not None else pkgutil.resolve_name(target)
    except Exception as err:  # not found, or the module fails on import (its own imports, a syntax error)
        what = f" (registered as {name!r})" if name is not None else ""
        raise ValueError(f"policy._target_={target}{what} cannot be imported ({_one_line(err)}); "
                         f"{_choices(registered)}") from err
    if not callable(factory):
        raise ValueError(f"policy._target_={target} is a {type(factory).__name__}, not a class or function; "
                         f"{_choices(registered)}")
    return factory, name


def unregistered_note(target: str) -> str:
    """rvn-eval's note for a ``_target_`` built by its dotted path."""
    return f"policy._target_={target} is not a registered policy (entry points {POLICIES_GROUP}), imported by its " \
           f'dotted path; to register it, add name = "module:attr" under [project.entry-points."{POLICIES_GROUP}"] ' \
           "in its package's pyproject.toml and pip install -e that package"


def _choices(registered: dict[str, EntryPoint]) -> str:
    if not registered:
        return (f"no package registers a policy (entry points {POLICIES_GROUP}); the installed metadata is stale: "
                "run pip install -e . in RVN's checkout")
    return f"registered policies (entry points {POLICIES_GROUP}): {', '.join(sorted(registered))} (choose one: policy=<name>)"


def _one_line(err: BaseException) -> str:
    return " ".join(str(err).split()) or type(err).__name__
