"""The choices of the training settings rvn-train and rvn-rl share, in one place and without torch, so that
rvn-rl's settings schema (`rvn_rl.settings`, torch-free) and benchmarks/node.py's parser import them as rvn-train's
checks do (`rvn_il.train.preflight`). `check_precision_on` asks torch, imported when a CUDA device is given."""
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


def check_precision_on(value: str, device) -> None:
    """train.precision=bf16 on a CUDA GPU without bfloat16 (before Ampere) would fail inside autocast at the first
    step: a one-line ValueError naming the GPU instead. CPUs run bf16 (emulated where they lack it: slow, not wrong)."""
    if value == "bf16" and getattr(device, "type", None) == "cuda":
        import torch

        if not torch.cuda.is_bf16_supported():
            raise ValueError(f"train.precision=bf16: {torch.cuda.get_device_name(device)} has no bfloat16 "
                             "(GPUs from Ampere on); use train.precision=fp32")
