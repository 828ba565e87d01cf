"""Exponential moving average of a model's weights, with the warm-up decay of diffusers'
(0.11.1) EMAModel that NoMaD used: the k-th update (k = 1, 2, ...) takes decay = clamp(1 - (k - 1)^-power, 0,
max_decay), 0 for the first two. Integer buffers are copied."""
from __future__ import annotations

import torch
from torch import nn


class EMA:
    def __init__(self, model: nn.Module, power: float = 0.75, max_decay: float = 0.9999):
        self.power, self.max_decay, self.step = float(power), float(max_decay), 0
        self.shadow = {k: v.detach().clone() for k, v in model.state_dict().items()}
        self._params: tuple | None = None  # (model, its float parameters' shadows, the parameters, the others' pairs)

    def decay(self) -> float:
        """The decay the next update takes."""
        s = self.step - 1
        return 0.0 if s <= 0 else min(self.max_decay, max(0.0, 1.0 - (1.0 + s) ** -self.power))

    def _parameters(self, model: nn.Module) -> tuple:
        """The model's parameters beside their shadows, found once per model: a Parameter stays the same object when
        its data is replaced (``.to()``), so it can be kept. A ``state_dict()`` per update walked every module: on
        the GPU node ~11 ms of host time a NoMaD full step (docs/results/2026-11-27_gpu3)."""
        if self._params is None or self._params[0] is not model:
            named = list(model.named_parameters(remove_duplicate=False))  # each is in the state_dict: a KeyError if not
            floats = [(self.shadow[k], p) for k, p in named if p.is_floating_point()]
            self._params = (model, [s for s, _ in floats], [p for _, p in floats],
                            [(self.shadow[k], p) for k, p in named if not p.is_floating_point()])
        return self._params

    @torch.no_grad()
    def update(self, model: nn.Module) -> None:
        """shadow <- lerp(shadow, model, 1 - decay) for every floating-point tensor of the model's state_dict; the
        others (integer buffers such as BatchNorm's step count) are copied. Buffers are read each update, since
        ``.to()`` replaces them."""
        d = self.decay()  # from the updates before this one, as diffusers 0.11.1's EMAModel.step: 0 at the first two
        self.step += 1
        _, floats_s, floats_m, others = self._parameters(model)
        floats_s, floats_m = list(floats_s), list(floats_m)
        for s, v in others:
            s.copy_(v)
        for k, v in model.named_buffers(remove_duplicate=False):
            if k in self.shadow:
                if v.is_floating_point():
                    floats_s.append(self.shadow[k])
                    floats_m.append(v)
                else:
                    self.shadow[k].copy_(v)
        torch._foreach_lerp_(floats_s, floats_m, 1.0 - d)

    def state_dict(self) -> dict:
        return {"step": self.step, "power": self.power, "max_decay": self.max_decay}

    def load_state_dict(self, state: dict, shadow: dict[str, torch.Tensor]) -> None:
        self.step, self.power, self.max_decay = int(state["step"]), float(state["power"]), float(state["max_decay"])
        for k, v in shadow.items():
            self.shadow[k].copy_(v)
