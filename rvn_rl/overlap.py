"""``train.overlap``: PPO updates in a learner thread while the envs collect the next rollout. The rollouts are
acted by a copy of the policy (`make_actor`) that takes the learner's weights after each update, so a rollout is
collected by the weights from before the update that runs beside it: one update of policy lag, as asynchronous
PPO (the update's ratio and clipping are against the log-probabilities of the policy that acted, which the rollout
keeps). The learner thread reads one rollout buffer while the collection writes the other (`rvn_rl.trainer._loop`)."""
from __future__ import annotations

import copy
from concurrent.futures import Future, ThreadPoolExecutor

import torch
from torch import nn

from .settings import TrainSettings


def make_actor(policy: nn.Module, train: TrainSettings) -> nn.Module:
    """The rollouts' copy of ``policy`` (made before ``policy``'s trunk is compiled): the same weights, buffers and
    ``train.precision``, in eval mode, without gradients and not compiled (an act is a small batch; the learner
    thread alone records CUDA graphs)."""
    actor = copy.deepcopy(policy)
    for m in actor.modules():  # a deep copy gives each LSTM weight a storage of its own: cuDNN then compacts
        if isinstance(m, nn.RNNBase):  # them at every call (its warning on the first GPU run of train.overlap)
            m.flatten_parameters()
    actor.autocast_bf16 = train.precision == "bf16"
    actor.eval()
    for p in actor.parameters():
        p.requires_grad_(False)
    return actor


class LearnerThread:
    """Runs the PPO updates: with ``threaded``, in one thread of its own for the whole run (torch.compile's CUDA
    graph trees belong to the thread that records them; torch's intra-op threads are set there as in the caller) and,
    on a GPU ``device``, on a CUDA stream of its own, so that the actor's forwards on the default stream do not queue
    behind the update's kernels (the stream is synchronised before the future is done and the actor reads the weights);
    else at once in the caller's thread. `start` returns a future of the update's losses."""

    def __init__(self, threaded: bool, device=None):
        self._pool, self._stream = None, None
        if threaded:
            threads = torch.get_num_threads()
            self._pool = ThreadPoolExecutor(1, thread_name_prefix="rvn-rl-learner",
                                            initializer=torch.set_num_threads, initargs=(threads,))
            if device is not None and torch.device(device).type == "cuda":
                self._stream = torch.cuda.Stream(torch.device(device))

    def _run(self, fn, args: tuple):
        if self._stream is None:
            return fn(*args)
        with torch.cuda.stream(self._stream):
            out = fn(*args)
        self._stream.synchronize()  # the new weights are whole before the actor reads them
        return out

    def start(self, fn, *args) -> Future:
        if self._pool is not None:
            if self._stream is not None:  # after what the caller queued: the actor's copy of the last weights
                self._stream.wait_stream(torch.cuda.current_stream(self._stream.device))
            return self._pool.submit(self._run, fn, args)
        done = Future()
        done.set_result(fn(*args))
        return done

    def close(self) -> None:
        if self._pool is not None:
            self._pool.shutdown(wait=True)
