"""`ProcessBatchEnv`: the envs of a `BatchEnv` split over worker processes (``env.workers``),
so stepping and rendering use several cores while the learner's process waits. Same
interface and same same-step autoreset as `BatchEnv`; worker ``w`` owns envs
``[offsets[w], offsets[w+1])`` with the same reset seeds as in one process, and its share of
the cores, cores // workers CPU threads (`rvn_data.worker_threads`). The depth function (a
network) runs in the calling process on the gathered RGB batch. `make_envs` makes a run's envs, in this process
(`BatchEnv`) or in ``env.workers`` worker processes.

Observations travel through shared memory (`ObsBlocks`): a worker writes its envs' arrays into
blocks it made at its first reply and sends only rewards, flags and episode records through its
pipe; the caller copies the blocks out before it sends the next command, so a returned batch is
never overwritten. Pickling frames through the pipes had cost the learner's process about 40 µs
per env step at 128² RGB and 160 µs with depth (benchmarks/env_transport.py: 32 envs in 8 workers)."""
from __future__ import annotations

import multiprocessing as mp
from multiprocessing import shared_memory

import numpy as np

from rvn_data.warning_lines import install_from_env
from rvn_data.worker_logs import Forwarder, log_to
from rvn_data.worker_threads import settle_worker_threads, threads_per_worker, worker_threads

from .settings import EnvSettings
from .vec_env import BatchEnv, quiet_scene_logs


class ObsBlocks:
    """A worker's observation arrays in shared memory, one block per key: made by the worker
    (``write``, which returns the blocks' layout the first time and None after), opened by the
    caller (``attach``, then `gather_obs`); the worker unlinks them at ``close``."""

    def __init__(self):
        self.blocks, self.arrays = [], {}

    def write(self, obs: dict) -> dict | None:
        layout = None
        if not self.arrays:
            layout = {}
            for key, value in obs.items():
                block = shared_memory.SharedMemory(create=True, size=max(1, value.nbytes))
                self.blocks.append(block)
                self.arrays[key] = np.ndarray(value.shape, value.dtype, buffer=block.buf)
                layout[key] = (block.name, value.shape, value.dtype.str)
        for key, value in obs.items():
            self.arrays[key][...] = value
        return layout

    def attach(self, layout: dict) -> None:
        for key, (name, shape, dtype) in layout.items():
            block = shared_memory.SharedMemory(name=name)
            self.blocks.append(block)
            self.arrays[key] = np.ndarray(shape, np.dtype(dtype), buffer=block.buf)

    def close(self, unlink: bool = False) -> None:
        self.arrays = {}  # views first: a block with views into it cannot close
        for block in self.blocks:
            block.close()
            if unlink:
                block.unlink()
        self.blocks = []


def gather_obs(blocks: list[ObsBlocks], layouts: list) -> dict:
    """The workers' observations copied out of their blocks into one batch (``layouts``: each reply's first
    item, the blocks' layout on a worker's first reply, which attaches them, else None)."""
    for worker_blocks, layout in zip(blocks, layouts):
        if layout is not None:
            worker_blocks.attach(layout)
    return {k: np.concatenate([b.arrays[k] for b in blocks]) for k in blocks[0].arrays}


def _worker(conn, env_kwargs: dict, indices: list[int], seed: int, rank: int, scene_cache: int, threads: int,
            prefetch: bool = True, logs: tuple | None = None) -> None:
    if logs is not None:
        log_to(*logs)  # its log records in the run's (rvn_data.worker_logs)
    install_from_env()  # the run's warnings, said once (rvn_data.warning_lines)
    settle_worker_threads(threads)
    envs, blocks = None, ObsBlocks()
    try:
        envs = BatchEnv(env_kwargs, len(indices), seed=seed, rank=rank, scene_cache=scene_cache, index_offset=indices[0],
                        prefetch=prefetch)
        conn.send(("ok", None))
        while True:
            cmd, arg = conn.recv()
            if cmd == "reset":
                conn.send(("ok", (blocks.write(envs.reset()),)))
                quiet_scene_logs()
            elif cmd == "step":
                obs, reward, cost, done, infos = envs.step(arg)
                infos = [{"episode": i["episode"]} if "episode" in i else {} for i in infos]
                conn.send(("ok", (blocks.write(obs), reward, cost, done, infos)))
            else:
                break
    except Exception as err:  # reported to the caller as a one-line error
        conn.send(("error", f"{type(err).__name__}: {(str(err).splitlines() or [''])[0]}"))
    finally:
        if envs is not None:
            envs.close()
        blocks.close(unlink=True)
        conn.close()


def worker_bounds(num_envs: int, workers: int) -> np.ndarray:
    """Worker ``w``'s envs are ``[bounds[w], bounds[w + 1])``: ``num_envs`` split as evenly as they go."""
    return np.linspace(0, num_envs, workers + 1).round().astype(int)


def halves(bounds: np.ndarray) -> list[slice]:
    """The envs of the first and the second half of the workers of `worker_bounds` ``bounds`` (train.double_buffered:
    one half steps while the policy acts for the other), as slices of the batch; each holds whole workers (15 workers
    of 30 envs: 16 and 14)."""
    workers = len(bounds) - 1
    if workers < 2:
        raise ValueError(f"two halves of env workers need env.workers >= 2 (has {workers})")
    mid = int(bounds[(workers + 1) // 2])
    return [slice(0, mid), slice(mid, int(bounds[-1]))]


class ProcessBatchEnv:
    def __init__(self, env_kwargs: dict, num_envs: int, workers: int, seed: int = 0, rank: int = 0,
                 scene_cache: int = 2, depth_fn=None, prefetch: bool = True):
        if isinstance(workers, bool) or not isinstance(workers, int) or not 1 <= workers <= num_envs:
            raise ValueError(f"env.workers={workers!r} must be between 1 and env.num_envs={num_envs}")
        self.num_envs, self.depth_fn = num_envs, depth_fn
        ctx = mp.get_context("spawn")
        self.bounds = bounds = worker_bounds(num_envs, workers)
        threads = threads_per_worker(workers)  # each worker's share of the cores (rvn_data.worker_threads)
        self.conns, self.procs = [], []
        self._logs = Forwarder(ctx)  # the workers' log records (each env's first renderer) in the run's
        with worker_threads(threads):
            for w in range(workers):
                parent, child = ctx.Pipe()
                p = ctx.Process(target=_worker, daemon=True, args=(
                    child, env_kwargs, list(range(bounds[w], bounds[w + 1])), seed, rank, scene_cache, threads, prefetch,
                    self._logs.args))
                p.start()
                child.close()
                self.conns.append(parent)
                self.procs.append(p)
        self.blocks = [ObsBlocks() for _ in range(workers)]
        self._stepping: set[int] = set()  # workers with a step sent and not yet received
        for _ in self._gather():
            pass

    def _gather(self, workers: range | None = None) -> list:
        out = []
        for w in range(len(self.conns)) if workers is None else workers:
            status, value = self.conns[w].recv()
            if status == "error":
                self.close()
                raise ValueError(f"env worker: {value}")
            out.append(value)
        return out

    def _with_depth(self, obs: dict) -> dict:
        if self.depth_fn is not None and "depth" not in obs:
            obs["depth"] = np.asarray(self.depth_fn(obs["rgb"]), dtype=np.float32)
        return obs

    def reset(self) -> dict:
        for conn in self.conns:
            conn.send(("reset", None))
        return self._with_depth(gather_obs(self.blocks, [p[0] for p in self._gather()]))

    def halves(self) -> list[slice]:
        """`halves` of this batch's workers."""
        return halves(self.bounds)

    def _workers(self, envs: slice) -> range:
        """The workers that own exactly the envs ``envs`` (a slice of whole workers: `halves`, or all)."""
        start, stop, _ = envs.indices(self.num_envs)
        first, last = np.searchsorted(self.bounds, [start, stop])
        if self.bounds[first] != start or self.bounds[last] != stop or envs.step not in (None, 1):
            raise ValueError(f"envs {start}:{stop} are not whole workers (their bounds: {self.bounds.tolist()})")
        return range(int(first), int(last))

    def _span(self, workers: range) -> str:
        return f"{self.bounds[workers.start]}:{self.bounds[workers.stop]}"

    def send_step(self, actions, envs: slice = slice(None)) -> None:
        """Start the envs ``envs`` (whole workers) on ``actions`` (one each) and return at once; `recv_step` with the
        same slice collects their step. Each worker steps its envs in its own process meanwhile."""
        actions = np.asarray(actions).reshape(-1)
        workers = self._workers(envs)
        lo = self.bounds[workers.start]
        if actions.shape[0] != self.bounds[workers.stop] - lo:
            raise ValueError(f"ProcessBatchEnv.step: {actions.shape[0]} actions for "
                             f"{self.bounds[workers.stop] - lo} envs")
        if self._stepping.intersection(workers):
            raise RuntimeError(f"envs {self._span(workers)}: a step is already under way (recv_step first)")
        for w in workers:
            self.conns[w].send(("step", actions[self.bounds[w] - lo:self.bounds[w + 1] - lo]))
        self._stepping.update(workers)

    def recv_step(self, envs: slice = slice(None)):
        """(obs, reward, cost, done, infos) of the envs ``envs``' step that `send_step` started, as `BatchEnv.step`'s;
        infos hold only ``episode``."""
        workers = self._workers(envs)
        if not self._stepping.issuperset(workers):
            raise RuntimeError(f"envs {self._span(workers)}: no step under way (send_step first)")
        self._stepping.difference_update(workers)
        parts = self._gather(workers)
        obs = self._with_depth(gather_obs(self.blocks[workers.start:workers.stop], [p[0] for p in parts]))
        reward, cost, done = (np.concatenate([p[k] for p in parts]) for k in (1, 2, 3))
        return obs, reward, cost, done, [i for p in parts for i in p[4]]

    def step(self, actions):
        """(obs, reward, cost, done, infos) as `BatchEnv.step`; infos hold only ``episode``."""
        self.send_step(actions)
        return self.recv_step()

    def close(self) -> None:
        for blocks in getattr(self, "blocks", []):
            blocks.close()
        self.blocks = []
        for conn in self.conns:
            try:
                conn.send(("close", None))
            except (OSError, BrokenPipeError):
                pass
        for p in self.procs:
            p.join(timeout=10)
            if p.is_alive():
                p.terminate()
                p.join()
        # every worker ended by itself: its records are all sent (one killed may hold the log queue's lock)
        clean = all(p.exitcode == 0 for p in self.procs)
        self.conns, self.procs = [], []
        if getattr(self, "_logs", None) is not None:
            self._logs.close(clean)
            self._logs = None


def make_envs(env_kwargs: dict, env: EnvSettings, seed: int, rank: int = 0, depth_fn=None):
    """A run's ``env.num_envs`` environments (`RVNEnv` keyword arguments ``env_kwargs``, `RLConfig.env_kwargs`): in this
    process (``env.workers=0``) or split over worker processes; ``depth_fn`` predicts the depth channel."""
    common = dict(seed=seed, rank=rank, scene_cache=env.scene_cache, depth_fn=depth_fn, prefetch=env.prefetch_scenes)
    if not env.workers:
        return BatchEnv(env_kwargs, env.num_envs, **common)
    return ProcessBatchEnv(env_kwargs, env.num_envs, env.workers, **common)
