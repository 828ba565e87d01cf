"""The weight caches of the models' inference forms (:meth:`ConditionalUnet1D.packed_weights`,
:meth:`ObsEncoder.packed_weights`): weights repacked once for a decision loop's layout and kept on the
module until any of its parameters or buffers is replaced (a load, ``.to()``) or changed in place (an
optimiser step), which their data pointers and version counters tell (an inference tensor, made under
``torch.inference_mode``, has no version counter: its data pointer alone)."""
from __future__ import annotations

from typing import Callable

import torch
from torch import nn


def packed_cache(module: nn.Module, build: Callable[[], dict]) -> dict:
    """``build()`` (run without autograd) for ``module``'s current weights, cached on the module."""
    tables = module.__dict__.get("_packed_tables")  # every submodule's parameter and buffer dicts (entries may change)
    if tables is None:
        tables = module.__dict__["_packed_tables"] = [d for m in module.modules() for d in (m._parameters, m._buffers)]
    key = [(t.data_ptr(), -1 if t.is_inference() else t._version)  # inference tensors keep no version
           for d in tables for t in d.values() if t is not None]
    cache = module.__dict__.get("_packed_cache")
    if cache is not None and cache[0] == key:
        return cache[1]
    with torch.no_grad():
        packed = build()
    module.__dict__["_packed_cache"] = (key, packed)
    return packed
