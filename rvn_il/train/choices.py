"""The choices of the training settings rvn-train and rvn-rl share, in one place and without torch, so that
rvn-rl's settings schema (`rvn_rl.settings`, torch-free) and benchmarks/node.py's parser import them as rvn-train's
checks do (`rvn_il.train.preflight`)."""
from __future__ import annotations

PRECISIONS = ("fp32", "bf16")  # train.precision: float32, or bfloat16 autocast (weights and optimiser float32)
COMPILE_MODES = ("default", "reduce-overhead")  # train.compile_mode: torch.compile's modes


def _check(setting: str, value: object, choices: tuple[str, ...]) -> str:
    if value not in choices:
        raise ValueError(f"{setting}={value!r}; choose one of {', '.join(choices)}")
    return value


def check_precision(value: object) -> str:
    """``value`` of train.precision; a one-line ValueError naming the setting and its choices otherwise."""
    return _check("train.precision", value, PRECISIONS)


def check_compile_mode(value: object) -> str:
    """``value`` of train.compile_mode; a one-line ValueError naming the setting and its choices otherwise."""
    return _check("train.compile_mode", value, COMPILE_MODES)
