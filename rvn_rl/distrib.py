"""torch.distributed set-up for DD-PPO under torchrun (or srun setting the same variables):
one process group (NCCL on GPUs, gloo on CPU) on a TCPStore, and a prefix store that counts
the ranks that finished their rollout (straggler pre-emption, as habitat-baselines)."""
from __future__ import annotations

import datetime
import os
from dataclasses import dataclass

import torch
import torch.distributed as dist

from .config import world_size_from_env

SHORT_ROLLOUT_THRESHOLD = 0.25  # a rank collects at least this fraction of a rollout before it may stop


@dataclass
class Dist:
    rank: int = 0
    local_rank: int = 0
    world_size: int = 1
    store: object = None

    @property
    def enabled(self) -> bool:
        return self.world_size > 1

    def should_end_early(self, step: int, num_steps: int, update: int, sync_frac: float) -> bool:
        if not self.enabled or step < num_steps * SHORT_ROLLOUT_THRESHOLD:
            return False
        return int(self.store.add(f"done_{update}", 0)) >= sync_frac * self.world_size

    def rollout_done(self, update: int) -> None:
        if self.enabled:
            self.store.add(f"done_{update}", 1)


def init(backend: str, device: str) -> Dist:
    """Join the process group described by torchrun's environment (a no-op for one process); ``device`` is the
    run's device setting, from which backend=auto picks NCCL (a GPU) or gloo."""
    world = world_size_from_env()
    if world <= 1:
        return Dist()
    rank, local = int(os.environ["RANK"]), int(os.environ.get("LOCAL_RANK", "0"))
    if backend == "auto":
        on_gpu = device.startswith("cuda") or (device == "auto" and torch.cuda.is_available())
        backend = "nccl" if on_gpu else "gloo"
    if backend not in ("gloo", "nccl"):
        raise ValueError(f"ddppo.backend={backend!r}: choose auto, gloo or nccl")
    if backend == "nccl":
        torch.cuda.set_device(local)
    # torch's env:// rendezvous: under torchrun, a client of the launcher's own store (no port of ours to collide
    # with another job's); with MASTER_ADDR/MASTER_PORT set by hand, rank 0 hosts it there
    store, _, _ = next(dist.rendezvous("env://", rank=rank, world_size=world, timeout=datetime.timedelta(minutes=30)))
    dist.init_process_group(backend, store=dist.PrefixStore("pg", store), rank=rank, world_size=world)
    return Dist(rank, local, world, dist.PrefixStore("rollout_tracker", store))


def pick_device(setting: str, d: Dist) -> torch.device:
    """This process's device for the setting ``device`` (auto | cpu | cuda[:i]); a DD-PPO rank takes
    cuda:<local rank>."""
    if setting == "auto":
        setting = "cuda" if torch.cuda.is_available() else "cpu"
    if setting.startswith("cuda"):
        if not torch.cuda.is_available():
            raise ValueError(f"device={setting}: this torch finds no GPU; use device=cpu or auto")
        return torch.device("cuda", d.local_rank if d.enabled else torch.device(setting).index or 0)
    if setting != "cpu":
        raise ValueError(f"device={setting!r}: choose auto, cpu or cuda")
    return torch.device("cpu")


def all_sum(x: torch.Tensor) -> torch.Tensor:
    """Sum over ranks in place (a no-op in one process); CPU tensors travel through the GPU under NCCL."""
    if dist.is_available() and dist.is_initialized() and dist.get_world_size() > 1:
        if dist.get_backend() == "nccl" and x.device.type != "cuda":
            y = x.to(torch.device("cuda", torch.cuda.current_device()))
            dist.all_reduce(y)
            x.copy_(y.cpu())
        else:
            dist.all_reduce(x)
    return x


def shutdown() -> None:
    if dist.is_available() and dist.is_initialized():
        dist.destroy_process_group()
