"""Compiled paths of the point-goal models (issue 32): ``policy.compile`` for decisions and
``train.compile`` for rvn-train's step, both off by default.

Inference (:func:`compile_for_inference`): torch.compile (inductor) of the per-frame image encoder
and of one denoising step of NoMaD's U-Net (:meth:`ConditionalUnet1D.forward_packed`), each with
fixed shapes. On a CPU inductor fuses the many small operations of a one-frame / eight-sample
decision into C++ kernels; on CUDA the mode is ``reduce-overhead``, which replays each compiled
call as one CUDA graph, so a decision is no longer bound by launching a few thousand small
kernels. The sampling loop, its noise draws and the action adapter stay as they are, so a compiled
policy draws the same noise and its trajectories agree with the plain path to float rounding
(tests/test_compiled.py checks the actions over a sequence of frames).

Training (:func:`compile_for_training`): ``nn.Module.compile`` of the encoder, the Transformer and
the decoder (U-Net or ViNT's MLP) in place, so parameter names, checkpoints and the EMA are those
of the plain model; random draws are torch's, so losses agree with the plain fp32 step to float
rounding (same test file).

Compiled kernels are cached under the cache root (`rvn_data.cache_root.keep_compiled_kernels`):
the first run compiles (about a minute on a laptop's core), later runs load.
"""
from __future__ import annotations

from typing import Callable

import torch

from rvn_data.cache_root import cache_root, keep_compiled_kernels, kernels_placed


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
    """``model`` (eval mode, already on ``device``) with its frame encoder and, for NoMaD, its
    denoising step compiled for decisions (``model.frame_encoder``, ``model.denoise_step``)."""
    device = torch.device(device)
    model.frame_encoder = CompiledCall(model.obs_encoder, device)
    if hasattr(model, "noise_pred_net"):
        net = model.noise_pred_net
        if device.type == "cuda":  # the repacked weights stay where they are: CUDA graphs need not copy them in
            from torch._dynamo import mark_static_address

            for t in _tensors(net.packed_weights()):
                mark_static_address(t)
        model.denoise_step = CompiledCall(net.forward_packed, device)
    return model


def _tensors(tree) -> list[torch.Tensor]:
    """Every tensor in nested dicts, lists and tuples."""
    if isinstance(tree, torch.Tensor):
        return [tree]
    items = tree.values() if isinstance(tree, dict) else tree if isinstance(tree, (list, tuple)) else ()
    return [t for item in items for t in _tensors(item)]


def compile_for_training(model: torch.nn.Module) -> torch.nn.Module:
    """``model`` with its encoder, Transformer and decoder compiled in place (``nn.Module.compile``:
    same parameters and state_dict keys). Training batches have one size (drop_last), so they compile once;
    validation runs on the validator's copy, which ``copy.deepcopy`` leaves uncompiled. Dropout and EfficientNet's drop-connect draw from torch's generator
    as in the plain model (inductor's ``fallback_random``), so the per-step seeds of rvn-train decide them."""
    from torch._inductor import config  # imported here: inductor adds a second to every rvn-train and rvn-eval start

    _kernel_cache()
    config.fallback_random = True
    for name in ("obs_encoder", "transformer", "noise_pred_net", "decoder"):
        part = getattr(model, name, None)
        if part is not None:
            part.compile()
    return model
