"""Compiled paths of the point-goal models (issue 32): ``policy.compile`` for decisions and
``train.compile`` for rvn-train's step, both off by default.

Inference (:func:`compile_for_inference`): torch.compile (inductor) of the per-frame image encoder (on a CPU its
inference form, :class:`PackedEncoder`) and, for NoMaD, of the whole sampling after it (:meth:`NoMaDPointGoal.sample_packed`: the context
Transformer's condition, the FiLM biases and all denoising steps with their updates, unrolled: see
:class:`PackedSampler`), each with fixed shapes, so a decision is three compiled calls on a CPU and
two CUDA graphs on a GPU. On a CPU inductor fuses the many small
operations of a one-frame / eight-sample decision into C++ kernels; on CUDA the mode is
``reduce-overhead``, which replays each compiled call as one CUDA graph, so a decision is no longer
bound by launching a few thousand small kernels. The noise is drawn before the sampling call
(:func:`rvn_il.models.sampling_plan.draw_noise`, in the plain loop's order) and the action adapter stays as it
is, so a compiled policy draws the same noise and its trajectories agree with the plain path to float
rounding (tests/test_compiled.py checks the actions over a sequence of frames).

Training (:func:`compile_for_training`): ``nn.Module.compile`` of the encoder, the Transformer and
the decoder (U-Net or ViNT's MLP) in place, so parameter names, checkpoints and the EMA are those
of the plain model; random draws are torch's, so losses agree with the plain fp32 step to float
rounding (same test file).

Compiled kernels are cached under the cache root (`rvn_data.cache_root.keep_compiled_kernels`):
the first run compiles (NoMaD full: 170 s on the 2-core development machine on 2026-11-28, 356 and 409 s on
2026-11-29, where inductor's own Python (lowering, scheduling, code generation) took ~300 s and waiting for its C++
compile processes ~50), later runs load (benchmarks/decision.py's compiled NoMaD full decisions, from the process's
start to 40 timed decisions: 166 s with an empty cache, 17 s with the first run's; 32.6-32.9 ms a decision either way,
the plain path ~42 ms; on 2026-11-29, 36.5-37.3 against 48.2-50.1 ms, 31 s from start with the cache).
Most of that Python is the C++ kernels' code generation, node by node (NoMaD small's denoising graph: ~1,560 nodes,
its vector tiling analysis in sympy the largest part). Inductor's settings do not shorten it at no cost there:
``cpp.enable_tiling_heuristics=False`` 134 against 138 s (8.3 against 7.7 ms a call), scalar kernels
(``cpp.vec_isa_ok=False``) 91 s but 27 ms a call (2026-11-29).
"""
from __future__ import annotations

import os
from typing import Callable

import torch
from torch import nn

from rvn_data.cache_root import cache_root, keep_compiled_kernels, kernels_placed

from ..train.choices import COMPILE_MODES


class CompiledCall:
    """``fn`` compiled for fixed shapes; on CUDA as CUDA graphs (``reduce-overhead``), whose output
    buffers are reused by the next replay, so the output is cloned there before it is returned (a
    policy keeps encoder tokens across decisions). Where the kernels are cached is settled at the first call,
    which compiles: a command (rvn-eval) places them under its cache root after its checks, once the policy
    is built."""

    def __init__(self, fn: Callable, device: torch.device):
        self.cuda = torch.device(device).type == "cuda"
        self.fn = torch.compile(fn, dynamic=False, mode="reduce-overhead" if self.cuda else None)
        self.called = False

    def __call__(self, *args):
        if not self.called:
            _kernel_cache()
            self.called = True
        if not self.cuda:
            return self.fn(*args)
        torch.compiler.cudagraph_mark_step_begin()
        return self.fn(*args).clone()


def check_compile(value: object, setting: str) -> bool:
    """``value`` of a true/false ``setting`` (policy.compile, train.compile); a ValueError naming it otherwise."""
    if not isinstance(value, bool):
        raise ValueError(f"{setting}={value!r}: give true or false")
    return value


def _kernel_cache() -> None:
    """Inductor's kernel cache under RVN's cache root, unless a command already put it somewhere."""
    if not kernels_placed():
        keep_compiled_kernels(cache_root())


def compile_for_inference(model: torch.nn.Module, device: torch.device | str) -> torch.nn.Module:
    """``model`` (eval mode, with its final weights, already on ``device``) with its frame encoder and,
    for NoMaD, its whole sampling (:meth:`NoMaDPointGoal.sample_packed`: condition, FiLM biases and
    every denoising step with its update) compiled for decisions (``model.frame_encoder``,
    ``model.sampling_graph``)."""
    device = torch.device(device)
    model.frame_encoder = PackedEncoder(model.obs_encoder, device) if device.type == "cpu" else \
        CompiledCall(model.obs_encoder, device)
    if hasattr(model, "noise_pred_net"):
        model.sampling_graph = PackedSampler(model, device)
    return model


class PackedEncoder:
    """The encoder's inference form (:func:`rvn_il.models.encoder_packed.encode_packed`) compiled, a CPU policy's
    frame encoder: its 1x1 convolutions are row products, which inductor leaves to aten's convolution in the module's
    form. NoMaD full, one frame, one thread of the development CPU: 7.2-8.0 ms against 8.3-9.2 compiled from the module
    (eager: 8.7-9.8 and 14.9-16.7), 37 against 53 s to compile. Its packed weights are buffers, as
    :class:`PackedSampler`'s; built from the encoder's current weights."""

    def __init__(self, encoder: nn.Module, device: torch.device):
        from .encoder_packed import encode_packed

        self.weights, self.layout = _as_buffers(encoder.packed_weights())
        self.call = CompiledCall(lambda images: encode_packed(_from_buffers(self.weights, self.layout), images), device)

    def __call__(self, images: torch.Tensor) -> torch.Tensor:
        return self.call(images)


class PackedSampler:
    """:meth:`NoMaDPointGoal.sample_packed` compiled: :meth:`NoMaDPointGoal.step_biases` (the condition
    and every step's FiLM biases), then :meth:`NoMaDPointGoal.denoise_packed` (every step and its
    update, unrolled).

    - The U-Net's repacked weights and the plan's FiLM timestep part are held as buffers, so that
      torch.compile sees them as a module's constants (guards and CUDA graphs treat them as fixed
      addresses) rather than as a nested dict of inputs to check at every call.
    - On a CPU the two parts are two compiled calls, and the biases enter the denoising graph as
      inputs, one tensor per step and block, so that every step's U-Net compiles to the same C++
      kernels. In one graph each step got kernels of its own, indexed into one tensor of all steps:
      157 kernels instead of 52 and 236 s of compiling instead of 172 (NoMaD small, 2-core development CPU).
    - On CUDA they are one call, one CUDA graph a decision, with four inputs to copy in (and more
      kernels to compile): as two graphs, each of the 150 bias tensors would be copied into the
      second graph's inputs.
    - All steps in one graph against one graph per step called ten times (its step's numbers given as a
      tensor), NoMaD full on one CPU core, same process: 36.7 ms against 40.3 ms a decision (plain
      55.9), for about two minutes more compiling, once per cache root. Measured again on 2026-11-29: the denoising
      steps compiled in 142 s as one graph and in 42 s as one step's (its weights one flat buffer), but the ten calls
      took 4.4-4.6 ms more a decision, timed in turns: each call checks its guards first (1,185 for one step, 0.36 ms).
    - What a compiled call checks before its kernels (NoMaD full, one thread of the development CPU): ~4,700 guards
      over a decision's three calls, 0.55-0.6 ms a call. The weights' and biases' tensors (125 buffers a part, 120
      bias inputs) cost the most: the layout's numbers as constants of generated code removed 2,500 guards but only
      ~0.1 ms a call; one flat weight buffer and one bias table, 0.25 ms a call, but a kernel per offset (162
      instead of 46 for the denoising steps) and a first compile of 290 s instead of 193. Left as it is.

    Built from the model's current weights: compile after loading them. Not a module itself, so that
    the model can hold it (as ``sampling_graph``) without becoming its own child."""

    def __init__(self, model: torch.nn.Module, device: torch.device):
        self.model = model
        with torch.no_grad():
            packed = model.noise_pred_net.packed_weights()
            part_t = model.plan_film_part(packed)
        # not film_timestep_part's cache (tuple keys)
        self.weights, self.layout = _as_buffers({k: v for k, v in packed.items() if isinstance(k, str)})
        self.weights.register_buffer("part_t", part_t, persistent=False)
        if device.type == "cuda":  # the weights stay where they are: CUDA graphs need not copy them in
            from torch._dynamo import mark_static_address

            for t in self.weights.buffers():
                mark_static_address(t)
            self.whole = CompiledCall(self._whole, device)
        else:
            self.biases, self.denoise, self.whole = CompiledCall(self._biases, device), CompiledCall(self._denoise, device), None

    def _packed(self) -> dict:
        return _from_buffers(self.weights, self.layout)

    def _biases(self, tokens: torch.Tensor, goal: torch.Tensor, goal_mask: torch.Tensor | None, rows: int):
        return self.model.step_biases(tokens, goal, goal_mask, rows, self._packed(), self.weights.part_t)

    def _denoise(self, x: torch.Tensor, noise: torch.Tensor, biases: list[list[torch.Tensor]]) -> torch.Tensor:
        return self.model.denoise_packed(x, noise, biases, self._packed())

    def _whole(self, tokens: torch.Tensor, goal: torch.Tensor, goal_mask: torch.Tensor | None,
               x: torch.Tensor, noise: torch.Tensor) -> torch.Tensor:
        return self._denoise(x, noise, self._biases(tokens, goal, goal_mask, x.shape[0]))

    def __call__(self, tokens: torch.Tensor, goal: torch.Tensor, goal_mask: torch.Tensor | None,
                 x: torch.Tensor, noise: torch.Tensor) -> torch.Tensor:
        """:meth:`NoMaDPointGoal.sample_packed`'s result for the same inputs, to float rounding."""
        if self.whole is not None:
            return self.whole(tokens, goal, goal_mask, x, noise)
        return self.denoise(x, noise, self.biases(tokens, goal, goal_mask, x.shape[0]))


def _as_buffers(tree) -> tuple[nn.Module, object]:
    """A module holding ``tree``'s tensors as its buffers, and ``tree``'s layout (:func:`_flatten`), so that
    torch.compile sees packed weights as a module's constants, not as a nested dict of inputs to guard at every call."""
    weights, flat = nn.Module(), []
    layout = _flatten(tree, flat)
    for i, t in enumerate(flat):
        weights.register_buffer(f"packed_{i}", t, persistent=False)
    return weights, layout


def _from_buffers(weights: nn.Module, layout):
    """The tree :func:`_as_buffers` took apart, from the module's buffers."""
    return _unflatten(layout, lambda i: getattr(weights, f"packed_{i}"))


def _flatten(tree, flat: list[torch.Tensor]):
    """``tree`` (dicts, lists, tuples of tensors and plain values) with each tensor replaced by its
    index in ``flat``, where it is appended."""
    if isinstance(tree, torch.Tensor):
        flat.append(tree)
        return _Slot(len(flat) - 1)
    if isinstance(tree, dict):
        return {k: _flatten(v, flat) for k, v in tree.items()}
    if isinstance(tree, (list, tuple)):
        return type(tree)(_flatten(v, flat) for v in tree)
    return tree


def _unflatten(tree, tensor: Callable[[int], torch.Tensor]):
    """The inverse of :func:`_flatten`: each slot replaced by ``tensor(index)``."""
    if isinstance(tree, _Slot):
        return tensor(tree.index)
    if isinstance(tree, dict):
        return {k: _unflatten(v, tensor) for k, v in tree.items()}
    if isinstance(tree, (list, tuple)):
        return type(tree)(_unflatten(v, tensor) for v in tree)
    return tree


class _Slot:
    """A tensor's place in a flattened tree."""

    def __init__(self, index: int):
        self.index = index


def compile_for_training(model: torch.nn.Module, mode: str = "default") -> torch.nn.Module:
    """``model`` with its encoder, Transformer and decoder compiled in place (``nn.Module.compile``:
    same parameters and state_dict keys). Training batches have one size (drop_last), so they compile once;
    validation runs on the validator's copy, which ``copy.deepcopy`` leaves uncompiled. Dropout and EfficientNet's drop-connect draw from torch's generator
    as in the plain model (inductor's ``fallback_random``), so the per-step seeds of rvn-train decide them. Under
    torchrun each rank's pool of compile processes is its share of the node's cores (`_share_compile_pool`).

    ``mode``: torch.compile's. ``reduce-overhead`` also replays each part's forward and backward as CUDA graphs on
    a GPU (on a CPU it compiles as ``default``); a step then begins with ``torch.compiler.cudagraph_mark_step_begin``.
    It is for steps bound by the host's launches: on an H200 a compiled NoMaD full step took 142 ms with 50 ms of
    kernels, and 51 ms with it (docs/results/2026-11-27_gpu3). rvn-train: ``train.compile_mode``."""
    from torch._inductor import config  # imported here: inductor adds a second to every rvn-train and rvn-eval start

    if mode not in COMPILE_MODES:
        raise ValueError(f"compile mode {mode!r}: choose one of {', '.join(COMPILE_MODES)}")
    _kernel_cache()
    config.fallback_random = True
    _share_compile_pool(config)
    for name in ("obs_encoder", "transformer", "noise_pred_net", "decoder"):
        part = getattr(model, name, None)
        if part is not None:
            part.compile(mode=None if mode == "default" else mode)
    return model


def _share_compile_pool(config) -> None:
    """Under torchrun every rank of a node compiles at once, and inductor starts a pool of one compile process per
    core in each (ranks x cores, each a Python process with torch loaded): unless TORCHINDUCTOR_COMPILE_THREADS says
    otherwise, each rank gets its share of the cores, as rvn-eval's workers do (`rvn_data.worker_threads`)."""
    from rvn_data.worker_threads import COMPILE_VAR, compile_threads, threads_per_worker

    ranks = int(os.environ.get("LOCAL_WORLD_SIZE") or 1)
    if ranks > 1 and COMPILE_VAR not in os.environ:
        config.compile_threads = compile_threads(threads_per_worker(ranks))
