"""Compiled paths of the point-goal models (issue 32): ``policy.compile`` for decisions and
``train.compile`` for rvn-train's step, both off by default.

Inference (:func:`compile_for_inference`): torch.compile (inductor) of the per-frame image encoder (on a CPU its
inference form, :class:`PackedEncoder`) and, for NoMaD, of the sampling after it
(:meth:`NoMaDPointGoal.sample_packed`: the context Transformer's condition and the FiLM biases, then the denoising
steps with their updates: see :class:`PackedSampler`), each with fixed shapes: on a CPU the encoder, the condition and
one denoising step are graphs (the step's called once a step), on a GPU a decision is two CUDA graphs (the encoder; the
whole sampling, its steps unrolled). On a CPU inductor fuses the many small
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

Compiled kernels are cached under the cache root (`rvn_data.cache_root.keep_compiled_kernels`): the first run
compiles, later runs load. A CPU's first compile is mostly inductor's own Python, above all the C++ kernels' code
generation node by node (its vector tiling analysis in sympy the largest part), so it grows with the graphs' nodes;
inductor's settings do not shorten it at no cost (``cpp.enable_tiling_heuristics=False``: 134 against 138 s for NoMaD
small's ten unrolled steps; scalar kernels, ``cpp.vec_isa_ok=False``: 91 s but 27 against 7.7 ms a call). One
denoising step's graph instead of ten unrolled (:class:`PackedSampler`, 2026-12-01): NoMaD full's first decision, cold
cache, one thread of the 2-core development machine (an Intel Xeon that day), 107 s against 241 s (the encoder's graph
included), at the same speed a decision after it (in turns: 37.1, 31.9, 44.2 against 37.1, 31.5, 42.5 ms);
``benchmarks/node.py --rows decision --compile on`` from a cold cache: 132 s for its three rows, compiled 34.2 ms
against 40.6 plain. On a CPU each graph compiles with inductor's C++ wrapper, one compiler call per graph
(:func:`rvn_il.models.graph_calls.cpp_wrapper`, which gives the figures).
"""
from __future__ import annotations

import os

import torch
from torch import nn

from ..train.choices import COMPILE_MODES
from .encoder_packed import encode_packed
from .graph_calls import (STRUCTURES, CompiledCall, KeyedCall, as_buffers, from_buffers, place_kernel_cache,
                          register_structure)
from .sampling_plan import coefficient_update, plan_coefficients
from .unet1d import unet_packed


def check_compile(value: object, setting: str) -> bool:
    """``value`` of a true/false ``setting`` (policy.compile, train.compile); a ValueError naming it otherwise."""
    if not isinstance(value, bool):
        raise ValueError(f"{setting}={value!r}: give true or false")
    return value


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
        self.weights, self.layout = as_buffers(encoder.packed_weights())
        self.structure = register_structure(("encode_packed",), self.weights, self.layout)
        self.call = KeyedCall(_encode, device)

    def __call__(self, images: torch.Tensor) -> torch.Tensor:
        return self.call(self.structure, self.weights, images)


def _encode(structure: int, weights: nn.Module, images: torch.Tensor) -> torch.Tensor:
    """:class:`PackedEncoder`'s graph (a :class:`KeyedCall`)."""
    layout, _ = STRUCTURES[structure]
    return encode_packed(from_buffers(weights, layout), images)


class PackedSampler:
    """:meth:`NoMaDPointGoal.sample_packed` compiled: :meth:`NoMaDPointGoal.step_biases` (the condition
    and every step's FiLM biases), then the denoising steps and their updates.

    - The U-Net's repacked weights and the plan's FiLM timestep part are held as buffers, so that
      torch.compile sees them as a module's tensors rather than as a nested dict of inputs.
    - On a CPU the condition is one compiled call and every denoising step another call of one graph
      (:func:`_denoise_step`, a :class:`KeyedCall`): the step's coefficients (:func:`plan_coefficients`), noise and
      FiLM biases are its inputs. NoMaD full, cold cache, one thread of the 2-core development CPU (2026-12-01): the
      first decision 107 s against 241 s with the ten steps unrolled in one graph, the same ms a decision after it.
      With every guard checked (1,185 a step, 0.36 ms) and the kernels' size checks, the ten calls had cost 4.4-4.6 ms
      more a decision than one unrolled graph (2026-11-29), which this sampler used from 2026-11-27 to 2026-12-01.
    - The biases enter the steps as inputs, one tensor per block, so that every step runs the same C++ kernels (indexed
      into one tensor of all steps, each step got kernels of its own: 157 instead of 52, NoMaD small).
    - On CUDA it is one call, one CUDA graph a decision (:meth:`NoMaDPointGoal.denoise_packed`'s steps unrolled), with
      four inputs to copy in: as two graphs, each of the 150 bias tensors would be copied into the second's inputs.
    - Guards: checking them took 0.55-0.6 ms a call with ~4,700 over a decision (2026-11-29), most for the weights and
      biases; the layout's numbers as constants of generated code removed 2,500 of them for ~0.1 ms a call, one flat
      weight buffer cost a kernel per offset (162 instead of 46) and a longer first compile. A :class:`KeyedCall`
      checks only its inputs' and a structure number's.

    Built from the model's current weights and sampling plan (``model.sampler``): compile after setting them. Not a
    module itself, so that the model can hold it (as ``sampling_graph``) without becoming its own child."""

    def __init__(self, model: torch.nn.Module, device: torch.device):
        self.model = model
        with torch.no_grad():
            packed = model.noise_pred_net.packed_weights()
            part_t = model.plan_film_part(packed)
        # not film_timestep_part's cache (tuple keys)
        self.weights, self.layout = as_buffers({k: v for k, v in packed.items() if isinstance(k, str)})
        self.weights.register_buffer("part_t", part_t, persistent=False)
        if device.type == "cuda":  # the weights stay where they are: CUDA graphs need not copy them in
            from torch._dynamo import mark_static_address

            for t in self.weights.buffers():
                mark_static_address(t)
            self.whole = CompiledCall(self._whole, device)
            return
        self.biases, self.step, self.whole = CompiledCall(self._biases, device), KeyedCall(_denoise_step, device), None
        self.plan = model._plan()
        self.rows = [row.clone() for row in plan_coefficients(self.plan)]  # each its own tensor, as the graph's input
        # what the graph reads of the plan: its kind (DDPM, DDIM), prediction type and clipping, the same for every step
        self.structure = register_structure((self.plan[0],), self.weights, self.layout)

    def _packed(self) -> dict:
        return from_buffers(self.weights, self.layout)

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
        x, noise = _in_this_mode(x), _in_this_mode(noise)  # as the steps' outputs and zeros: one graph, not two
        k, zeros = 0, torch.zeros_like(x)  # the noise of a step that draws none (DDPM's last, every DDIM step)
        for row, step, biases in zip(self.rows, self.plan, self.biases(tokens, goal, goal_mask, x.shape[0])):
            drawn, k = (noise[k], k + 1) if step.std else (zeros, k)
            x = self.step(self.structure, self.weights, x, drawn, row, biases)
        return x


def _in_this_mode(t: torch.Tensor) -> torch.Tensor:
    """``t``, copied where it is not of the current mode's kind (an inference tensor inside ``torch.inference_mode``, a
    normal one outside): dynamo guards the kind, and the steps' own tensors are of that mode."""
    return t.clone() if t.is_inference() != torch.is_inference_mode_enabled() else t


def _denoise_step(structure: int, weights: nn.Module, x: torch.Tensor, noise: torch.Tensor, row: torch.Tensor,
                  biases: list[torch.Tensor]) -> torch.Tensor:
    """One denoising step of :class:`PackedSampler` on a CPU (a :class:`KeyedCall`): the packed U-Net with the step's
    FiLM ``biases``, then its update with its coefficients ``row`` and ``noise`` (:func:`coefficient_update`)."""
    layout, step = STRUCTURES[structure]
    return coefficient_update(step, row, unet_packed(from_buffers(weights, layout), x, biases), x, noise)


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
    place_kernel_cache()
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
