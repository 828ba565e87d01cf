"""Compiled calls of fixed shapes for rvn_il.models.compiled's inference graphs (issue 32): :class:`CompiledCall`
(every guard dynamo makes; CUDA graphs on a GPU) and :class:`KeyedCall` (a CPU graph that checks only its inputs and a
structure number, :func:`register_structure`), with packed weights held as a module's buffers (:func:`as_buffers`)."""
from __future__ import annotations

import inspect
import os
import re
import zlib
from typing import Callable

import torch
from torch import nn

from rvn_data.cache_root import cache_root, keep_compiled_kernels, kernels_placed


class CompiledCall:
    """``fn`` compiled for fixed shapes; on CUDA as CUDA graphs (``reduce-overhead``), whose output
    buffers are reused by the next replay, so the output is cloned there before it is returned (a
    policy keeps encoder tokens across decisions). Where the kernels are cached is settled at the first call,
    which compiles: a command (rvn-eval) places them under its cache root after its checks, once the policy
    is built."""

    def __init__(self, fn: Callable, device: torch.device, options: dict | None = None):
        self.cuda = torch.device(device).type == "cuda"
        if self.cuda:
            self.fn = torch.compile(fn, dynamic=False, mode="reduce-overhead")
        else:  # the inputs' sizes and strides are guarded (or named by a structure number: KeyedCall), so the
            # kernels' own checks of them are left out (~135 for a U-Net step, 0.16 ms a call)
            self.fn = torch.compile(fn, dynamic=False, options={"size_asserts": False, "cpp_wrapper": cpp_wrapper(),
                                                                **(options or {})})
        self.called = False

    def __call__(self, *args):
        if not self.called:
            place_kernel_cache()
            self.called = True
        if not self.cuda:
            return self.fn(*args)
        torch.compiler.cudagraph_mark_step_begin()
        return self.fn(*args).clone()


def cpp_wrapper() -> bool:
    """Whether a CPU graph is compiled with inductor's C++ wrapper: its kernels and the code that calls them in one
    C++ file, one compiler call per graph, each kernel called from C++ rather than Python. Inductor's default, a
    Python wrapper, compiles each kernel alone, and each compiler call loads inductor's 140 MB precompiled header
    (~0.75 s). One thread of the 2-core development CPU: benchmarks/decision.py --compile from a cold kernel cache
    (every model, compiled and plain) took 261 against 419 CPU-s, 4 min 21 s against 5 min 4 s; NoMaD full's compiled
    decision then 27.2 and 27.4 ms against 29.4 and 35.0 (the plain path beside it x1.37-1.38 against x1.30-1.32, two
    runs each, alternating). On unless TORCHINDUCTOR_CPP_WRAPPER=0."""
    return os.environ.get("TORCHINDUCTOR_CPP_WRAPPER", "1") != "0"


# torch.compile's guard_filter_fn came with torch 2.8 (as these helpers did); before it a KeyedCall checks every guard
GUARD_FILTER = hasattr(torch.compiler, "skip_guard_on_globals_unsafe")


class KeyedCall(CompiledCall):
    """``fn(structure, weights, *inputs)`` compiled on a CPU, checking at each call only the guards of its own
    arguments but ``weights`` (the inputs' shapes and strides, the number ``structure``) and torch's global state.

    ``fn`` reads everything fixed about its graph from ``STRUCTURES[structure]`` (a packed layout, a plan's step: see
    :func:`register_structure`) and its weights from the module ``weights``, whose tensors stay the graph's inputs, read
    at each call. Dynamo otherwise guards every weight tensor and every number of the layout before each call (NoMaD
    full: ~1,200 guards for one denoising step, 0.36 ms; ~1,500 for the encoder), which is why one graph per denoising
    step, called ten times, cost 4.4-4.6 ms more a decision than the ten steps unrolled in one graph (2026-11-29). The
    number names the structure, so that two callers of different structure never share a graph and two of the same
    structure (NoMaD-Neg's two networks) share one. Leaving out guards is torch's ``guard_filter_fn`` (flagged unsafe):
    safe here because nothing else that the graph depends on can change without changing the number."""

    def __init__(self, fn: Callable, device: torch.device):
        if torch.device(device).type != "cpu":
            raise ValueError(f"KeyedCall compiles for the CPU, not {device}")
        names = [n for n in inspect.signature(fn).parameters if n != "weights"]

        def own_guards(entries) -> list[bool]:
            return [_kept(e, names) for e in entries]
        super().__init__(fn, device, {"guard_filter_fn": own_guards} if GUARD_FILTER else None)


def _kept(entry, names: list[str]) -> bool:
    """Whether a KeyedCall keeps the guard ``entry``: torch's global state ("" names) and its own arguments' guards
    (names rooted in one of ``names``), not globals; any guard that does not read as torch 2.13's entries do is kept
    (torch gives no compatibility promise for them)."""
    name, is_global = getattr(entry, "name", None), getattr(entry, "is_global", None)
    if not isinstance(name, str) or not isinstance(is_global, bool):
        return True
    return not is_global and (name == "" or re.match(r"\w*", name).group(0) in names)


STRUCTURES: dict[int, tuple] = {}  # what a KeyedCall's graph holds fixed, by its structure number
_DESCRIPTIONS: dict[int, str] = {}  # the description each number was made from (register_structure)


def register_structure(static: tuple, weights: nn.Module, layout) -> int:
    """The structure number of a graph over ``weights`` laid out as ``layout`` (:func:`as_buffers`) with the fixed
    parts ``static`` (plain values: what its function reads of them decides its graph): a CRC-32 of their description
    and of every weight's shape, stride and dtype, the next free number where another structure has it;
    ``STRUCTURES[number]`` is then ``(layout, *static)``."""
    shapes = tuple((tuple(t.shape), t.stride(), str(t.dtype), t.device.type) for t in weights.buffers())
    description = repr((layout, static, shapes))  # a layout's repr is its plain values and slots
    number = zlib.crc32(description.encode())
    while _DESCRIPTIONS.setdefault(number, description) != description:
        number += 1
    STRUCTURES[number] = (layout, *static)
    return number


def place_kernel_cache() -> None:
    """Inductor's kernel cache under RVN's cache root, unless a command already put it somewhere."""
    if not kernels_placed():
        keep_compiled_kernels(cache_root())


def as_buffers(tree) -> tuple[nn.Module, object]:
    """A module holding ``tree``'s tensors as its buffers, and ``tree``'s layout (:func:`_flatten`), so that
    torch.compile sees packed weights as a module's constants, not as a nested dict of inputs to guard at every call."""
    weights, flat = nn.Module(), []
    layout = _flatten(tree, flat)
    for i, t in enumerate(flat):
        weights.register_buffer(f"packed_{i}", t, persistent=False)
    return weights, layout


def from_buffers(weights: nn.Module, layout):
    """The tree :func:`as_buffers` took apart, from the module's buffers."""
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

    def __repr__(self) -> str:  # the same in any process (register_structure describes layouts by their repr)
        return f"_Slot({self.index})"
