"""``train.graph_act``: the rollouts' act replayed as one CUDA graph. On the fourth H200 run an act of 30 envs
(ResNet-18 at 128², the LSTM, the heads) took ~7.9 ms, of which 1.8 ms were kernels: the rest was the host launching
them one by one (docs/results/2026-12-04_gpu4). `GraphedAct` records the network's part of an act once for each
batch shape (train.double_buffered's two halves: two graphs): the frame's normalisation, the trunk, the embeddings,
one LSTM step, the heads' logits, probabilities, log-probabilities and values. It then replays it with one launch: the
inputs are copied into the graph's static buffers, and the action is drawn after the replay from the replayed
probabilities, by the same ``torch.multinomial`` and generator as `PointNavResNetPolicy.act`, so a graphed act gives
the plain act's actions.

The graph reads the actor's weights where they are: the optimiser (or train.overlap's `load_state_dict`) updates
them in place, which the next replay sees. It is recorded in eval mode with the trunk not compiled (train.compile's
trunk replays graphs of its own, which one graph cannot hold), at the first act of its shape, before the learner
thread starts.
"""
from __future__ import annotations

import logging

import torch
import torch.nn.functional as F
from torch import nn

logger = logging.getLogger(__name__)


class GraphedAct:
    """``actor`` (a `PointNavResNetPolicy`, or train.overlap's copy of it) whose ``act`` replays a CUDA graph; its
    forward, ``values``, ``eval`` and ``load_state_dict`` are the actor's. ``cuda_graph=False`` runs the same static
    buffers eagerly, a replay being one more forward (the tests' CPU check of everything but the recording)."""

    def __init__(self, actor: nn.Module, cuda_graph: bool = True):
        self.actor, self.cuda_graph = actor, cuda_graph
        # one recording per batch shape (train.double_buffered acts for two halves of the envs, of 16 and 14 in
        # scale=small): its static (obs, state, prev_actions, masks), static (logits, probs, logp_all, values, state)
        # and graph (None without CUDA graphs)
        self._records: dict[tuple, _Recording] = {}
        self.recorded = 0  # graphs recorded (one a shape: one a run, two with train.double_buffered's halves)

    def __call__(self, *args, **kwargs):
        return self.actor(*args, **kwargs)

    def values(self, feats: torch.Tensor) -> torch.Tensor:
        return self.actor.values(feats)

    def eval(self) -> "GraphedAct":
        self.actor.eval()
        return self

    def load_state_dict(self, state_dict: dict):
        return self.actor.load_state_dict(state_dict)  # copies into the weights the graph reads

    @property
    def graphs(self) -> list:
        """The CUDA graphs recorded (none without CUDA graphs, or where recording failed)."""
        return [r.graph for r in self._records.values() if r.graph is not None]

    def act(self, obs: dict, state: torch.Tensor, prev_actions: torch.Tensor, masks: torch.Tensor,
            deterministic: bool = False, generator: torch.Generator | None = None):
        """`PointNavResNetPolicy.act`'s (action, log-prob, values, new state), by a replay."""
        key = _shapes(obs, state, prev_actions, masks)
        rec = self._records.get(key)
        fresh = rec is None
        if fresh:  # static buffers for these shapes, filled below, then the graph recorded on their values
            device = state.device
            rec = self._records[key] = _Recording(
                ({k: torch.empty_like(v, device=device) for k, v in obs.items()}, torch.empty_like(state),
                 torch.empty_like(prev_actions, device=device), torch.empty_like(masks, device=device)))
        s_obs, s_state, s_prev, s_masks = rec.inputs
        for k, v in obs.items():
            s_obs[k].copy_(v, non_blocking=True)
        s_state.copy_(state, non_blocking=True)
        s_prev.copy_(prev_actions, non_blocking=True)
        s_masks.copy_(masks, non_blocking=True)
        if fresh:
            self._record(rec, state.device)
        if rec.graph is not None:
            rec.graph.replay()
        else:
            rec.outputs = self._forward(rec.inputs)
        logits, probs, logp_all, values, new_state = rec.outputs
        if deterministic:
            action = logits.argmax(-1)
        else:
            action = torch.multinomial(probs, 1, generator=generator).squeeze(-1)
        logp = logp_all.gather(-1, action[:, None]).squeeze(-1)
        # copies: the next replay overwrites the static outputs
        return action, logp, values.clone(), new_state.clone()

    def _forward(self, inputs: tuple) -> tuple:
        """The act's network part on the static inputs (what the graph holds)."""
        s_obs, s_state, s_prev, s_masks = inputs
        with torch.no_grad(), self.actor.eager_visual():
            feats, new_state = self.actor(s_obs, s_state, s_prev, s_masks)
            logits = self.actor.actor(feats)
            return logits, F.softmax(logits, -1), F.log_softmax(logits, -1), self.actor.values(feats), new_state

    def _record(self, rec: "_Recording", device: torch.device) -> None:
        """The graph of `_forward` on ``rec``'s static inputs, which hold the first act's values (for the warm-up
        passes)."""
        if not self.cuda_graph:
            self.recorded += 1
            return
        training = self.actor.training
        self.actor.eval()
        try:
            with torch.cuda.device(device):
                side = torch.cuda.Stream()
                side.wait_stream(torch.cuda.current_stream())
                with torch.cuda.stream(side):  # cuDNN's and cuBLAS's first calls (workspaces, plans) outside the graph
                    for _ in range(3):
                        self._forward(rec.inputs)
                torch.cuda.current_stream().wait_stream(side)
                graph = torch.cuda.CUDAGraph()
                with torch.cuda.graph(graph, capture_error_mode="thread_local"):
                    rec.outputs = self._forward(rec.inputs)
                rec.graph = graph
        except RuntimeError as e:  # an op CUDA graphs cannot hold: the same acts, launched one by one
            logger.warning("train.graph_act: recording the act as a CUDA graph failed (%s); acting without it",
                           str(e).splitlines()[0] if str(e) else type(e).__name__)
            self.cuda_graph = False
            for other in self._records.values():
                other.graph = None
        finally:
            self.actor.train(training)
        self.recorded += 1


class _Recording:
    """One batch shape's static inputs, static outputs and CUDA graph (None: the static path run eagerly)."""

    def __init__(self, inputs: tuple):
        self.inputs, self.outputs, self.graph = inputs, None, None


def _shapes(obs: dict, *tensors: torch.Tensor) -> tuple:
    """An act's input shapes: its recording's key."""
    return (tuple((k, tuple(v.shape)) for k, v in obs.items()), *(tuple(t.shape) for t in tensors))
