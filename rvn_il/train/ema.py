"""Exponential moving average of a model's weights, with the warm-up decay of diffusers'
(0.11) EMAModel that NoMaD used: decay = clamp(1 - (1 + step)^-power, 0, max_decay), 0 at the
first update. Integer buffers are copied."""
from __future__ import annotations

import torch
from torch import nn


class EMA:
    def __init__(self, model: nn.Module, power: float = 0.75, max_decay: float = 0.9999):
        self.power, self.max_decay, self.step = float(power), float(max_decay), 0
        self.shadow = {k: v.detach().clone() for k, v in model.state_dict().items()}

    def decay(self) -> float:
        s = self.step - 1
        return 0.0 if s <= 0 else min(self.max_decay, max(0.0, 1.0 - (1.0 + s) ** -self.power))

    @torch.no_grad()
    def update(self, model: nn.Module) -> None:
        self.step += 1
        d = self.decay()
        floats_s, floats_m = [], []
        for k, v in model.state_dict().items():
            if v.dtype.is_floating_point:
                floats_s.append(self.shadow[k])
                floats_m.append(v.detach())
            else:
                self.shadow[k].copy_(v)
        torch._foreach_lerp_(floats_s, floats_m, 1.0 - d)

    def state_dict(self) -> dict:
        return {"step": self.step, "power": self.power, "max_decay": self.max_decay}

    def load_state_dict(self, state: dict, shadow: dict[str, torch.Tensor]) -> None:
        self.step, self.power, self.max_decay = int(state["step"]), float(state["power"]), float(state["max_decay"])
        for k, v in shadow.items():
            self.shadow[k].copy_(v)
