"""Run a policy over an episode set, in this process or in worker processes.

Each worker builds its own `RVNEnv` (eval mode) and policy from the same `EvalJob` (in one process, the policy
rvn-eval built to check it); episodes are addressed by their position in the set's schedule, so the records
do not depend on the number of workers. The policy config's ``_target_`` is resolved through the policies
installed packages register (entry point group ``rvn.policies``, :mod:`.policy_registry`) and called with the
config's other keys: any object with ``reset()`` and ``act(obs)`` is a policy; one with ``bind(env)`` gets the
env (privileged state) once.
"""
from __future__ import annotations

import operator
import sys
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass

import numpy as np

from rvn_data.benchmark.episodes_source import EnvConfig
from rvn_data.benchmark.traces import TraceRecorder
from rvn_data.conventions import Action
from rvn_data.numba_note import note_first_compile
from rvn_data.warning_lines import install_from_env
from rvn_data.worker_logs import spawned_pool
from rvn_data.worker_threads import settle_worker_threads, threads_per_worker



class InvalidActionError(ValueError):
    """A policy returned something that is not an `Action`."""


@dataclass(frozen=True)
class EvalJob:
    """What every worker of one evaluation builds from: the env's settings, the policy's config (``_target_``, a
    registered policy's dotted path, and its keyword settings; `make_policy`), the row's name and the run's seed."""

    env: EnvConfig
    policy: dict
    name: str
    seed: int = 0
    paths: bool = False  # each record carries its episode's trace under "trace" (`rvn_data.benchmark.traces`)


def make_policy(policy_cfg: dict, env, name: str):
    """Build a policy config: its ``_target_``'s class or factory (`policy_registry.policy_factory`: the registered
    entry point that names it, else its dotted path) called with the config's other keys as plain dicts and lists;
    bound to ``env`` when it has ``bind`` (and ``env`` is not None: rvn-eval builds it once without an env to check
    it before any work)."""
    from rvn_data.benchmark.policy_registry import policy_factory

    settings = plain_settings(policy_cfg)
    factory, _ = policy_factory(settings.pop("_target_", None))
    try:
        policy = factory(**settings)
    except Exception as err:  # the policy's own check (a missing checkpoint, a bad setting): one line naming it
        raise ValueError(f"policy {name!r}: {err}{_valid_settings(factory, err)}") from err
    for method in ("reset", "act"):
        if not callable(getattr(policy, method, None)):
            raise TypeError(f"policy {name!r} ({type(policy).__name__}) has no {method}() method; "
                            "a policy needs reset() and act(obs) -> int")
    return bind_policy(policy, env)


def bind_policy(policy, env):
    """``policy`` bound to ``env`` when it has ``bind`` (and ``env`` is not None); the policy."""
    if env is not None and callable(getattr(policy, "bind", None)):
        policy.bind(env)
    return policy


def plain_settings(policy_cfg) -> dict:
    """A policy config (a mapping or an OmegaConf node) as a new plain dict, interpolations resolved, nested
    mappings and sequences as dicts and lists (what ``hydra.utils.instantiate(..., _convert_="all")`` handed the
    target); a ValueError for a nested ``_target_`` or another of Hydra's ``_x_`` keys: no policy config has one,
    and rvn-eval builds only the policy's own ``_target_``."""
    from omegaconf import OmegaConf

    cfg = OmegaConf.to_container(OmegaConf.create(dict(policy_cfg), flags={"allow_objects": True}), resolve=True)

    def check(value, key: str) -> None:
        if isinstance(value, dict):
            for k, v in value.items():
                hydra_key = str(k).startswith("_") and str(k).endswith("_")  # _target_, _args_, _partial_, ...
                if hydra_key and (key or k != "_target_"):  # only the policy's own, top-level _target_ is built
                    raise ValueError(f"policy.{key}{k}: rvn-eval builds the policy's own _target_ with plain keyword "
                                     "settings; nested objects and Hydra's instantiate keys are not built")
                check(v, f"{key}{k}.")
        elif isinstance(value, list):
            for i, v in enumerate(value):
                check(v, f"{key}{i}.")

    check(cfg, "")
    return cfg


def _valid_settings(factory, cause: BaseException) -> str:
    """``; policy settings: a, b (nearest: a)`` for an unexpected keyword, from the class's signature."""
    import difflib
    import inspect
    import re

    m = re.search(r"unexpected keyword argument '(\w+)'", str(cause))
    if m is None:
        return ""
    try:
        params = [p for p in inspect.signature(factory).parameters if p not in ("self", "env")]
    except (ValueError, TypeError):
        return ""
    close = difflib.get_close_matches(m.group(1), params, n=2, cutoff=0.6)
    return f"; policy.* settings: {', '.join(params) or 'none'}" + (f" (nearest: {', '.join(close)})" if close else "")


def check_action(action, name: str) -> int:
    """The action as an int, or InvalidActionError naming the policy and the value."""
    try:
        a = operator.index(action.item() if isinstance(action, np.ndarray) and action.size == 1 else action)
    except TypeError:
        a = None
    if a is None or isinstance(action, bool) or not 0 <= a < len(Action):
        raise InvalidActionError(
            f"policy {name!r} returned invalid action {action!r}; expected an int in 0..{len(Action) - 1} "
            f"({', '.join(f'{x.value}={x.name}' for x in Action)})")
    return a


def seed_frameworks(key: Iterable[int]) -> None:
    """Seed torch's global generator per episode (only if a policy imported torch)."""
    torch = sys.modules.get("torch")
    if torch is not None:
        torch.manual_seed(int(np.random.default_rng(list(key)).integers(2**31 - 1)))


def run_episode(env, policy, k: int, name: str, seed: int = 0, trace: bool = False) -> dict:
    """Run episode ``k`` of the env's eval schedule to its end; returns its record. A policy with
    ``episode_stats() -> dict`` (counts since its ``reset()``, e.g. depth vetoes) has them recorded
    under ``policy_stats``. ``trace``: the record carries the episode's poses under ``"trace"``
    (`rvn_data.benchmark.traces`; rvn-eval writes them to a file of their own)."""
    obs, _ = env.reset(options={"episode": int(k)})
    seed_frameworks([seed, *env.unwrapped.episode_key])
    policy.reset()
    poses = TraceRecorder(env) if trace else None
    while True:
        action = check_action(policy.act(obs), name)
        obs, _, terminated, truncated, info = env.step(action)
        if poses is not None:
            poses.step(info)
        if terminated or truncated:
            rec = info["episode"]
            stats = getattr(policy, "episode_stats", None)
            if callable(stats):
                rec["policy_stats"] = {str(key): int(v) for key, v in dict(stats()).items()}
            if poses is not None:
                rec["trace"] = poses.arrays(rec)
            return rec


_WORKER: dict = {}


def _init_worker(job: EvalJob, threads: int | None = None, policy=None) -> None:
    """Build this process's env and policy (or bind ``policy``, built from ``job.policy`` without an env); in a
    worker process (``threads``: its share of the cores, `_pool`) its CPU threads are settled first."""
    from rvn_data.benchmark.env import RVNEnv

    if threads is not None:
        settle_worker_threads(threads)
    env = RVNEnv(config=job.env)
    policy = make_policy(job.policy, env, job.name) if policy is None else bind_policy(policy, env)
    _WORKER.update(env=env, policy=policy, name=job.name, seed=job.seed, paths=job.paths)


def _run_task(k: int) -> tuple[int, dict]:
    w = _WORKER
    return k, run_episode(w["env"], w["policy"], k, w["name"], w["seed"], w["paths"])


def _prepare_task(args) -> int:
    from rvn_data.benchmark.episodes_source import ensure_scene_episodes

    env, slot = args
    return ensure_scene_episodes(env, slot)


def _pool(workers: int, job: EvalJob | None = None):
    """``workers`` processes, each with its share of the cores, logging through this process's handlers
    (`rvn_data.worker_logs.spawned_pool`); with ``job``, each builds its env and policy first."""
    threads = threads_per_worker(workers)
    return spawned_pool(workers, threads, _start_worker, (threads, job))


def _start_worker(threads: int, job: EvalJob | None) -> None:
    """A worker's start: the run's warnings as the run says them (`rvn_data.warning_lines`), its CPU threads, and with
    ``job`` its env and policy."""
    install_from_env()
    if job is None:
        settle_worker_threads(threads)
    else:
        _init_worker(job, threads)


def prepare_episodes(env: EnvConfig, slots: list, workers: int, progress: Callable | None = None) -> None:
    """Generate and cache the episode files of every scene (in parallel when workers > 1 and there are several
    scenes: a pool of one would only start a process)."""
    note_first_compile("rvn-eval")
    tasks = [(env, slot) for slot in slots]
    if not tasks:  # every episode already done (a resumed run): no pool of zero processes
        return
    workers = min(workers, len(tasks))
    if workers <= 1:
        for t in tasks:
            _prepare_task(t)
            if progress:
                progress(1)
        return
    with _pool(workers) as pool:
        for _ in pool.imap_unordered(_prepare_task, tasks):
            if progress:
                progress(1)


def run_episodes(job: EvalJob, todo: list[int], workers: int, policy=None) -> Iterator[tuple[int, dict]]:
    """Yield (k, record) for the schedule positions ``todo`` (completion order). ``policy``: one already built from
    ``job.policy`` with no env (rvn-eval's check), used in this process rather than building another (a
    checkpoint policy loads in about a second); worker processes build their own. Never more workers than
    episodes: one episode left (a tiny run, a resumed one) runs here, not in a pool of one that would start a process,
    import torch and load the policy again."""
    if not todo:
        return
    workers = min(workers, len(todo))
    if workers <= 1:
        _init_worker(job, policy=policy)
        try:
            for k in todo:
                yield _run_task(k)
        finally:
            _WORKER.pop("env").close()
            _WORKER.clear()
        return
    with _pool(workers, job) as pool:
        yield from pool.imap_unordered(_run_task, todo)
