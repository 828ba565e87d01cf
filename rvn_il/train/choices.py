"""The choices of the training settings rvn-train and rvn-rl share, in one place and without torch, so that
rvn-rl's settings schema (`rvn_rl.settings`, torch-free) and benchmarks/node.py's parser import them as rvn-train's
checks do (`rvn_il.train.preflight`). `check_precision_on` asks torch, imported when a CUDA device is given; `fused_on`
is both optimisers' ``fused``, which `load_optimizer_state` applies on resuming."""
from __future__ import annotations

PRECISIONS = ("fp32", "bf16")  # train.precision: float32, or bfloat16 autocast (weights and optimiser float32)
COMPILE_MODES = ("default", "reduce-overhead")  # train.compile_mode: torch.compile's modes
TRAIN_COMPILE_MODES = ("auto", *COMPILE_MODES)  # rvn-train's: auto picks by device and ranks (`training_compile_mode`)


def _check(setting: str, value: object, choices: tuple[str, ...]) -> str:
    if value not in choices:
        raise ValueError(f"{setting}={value!r}; choose one of {', '.join(choices)}")
    return value


def check_precision(value: object) -> str:
    """``value`` of train.precision; a one-line ValueError naming the setting and its choices otherwise."""
    return _check("train.precision", value, PRECISIONS)


def check_compile_mode(value: object, choices: tuple[str, ...] = COMPILE_MODES) -> str:
    """``value`` of train.compile_mode; a one-line ValueError naming the setting and its choices otherwise."""
    return _check("train.compile_mode", value, choices)


def training_compile_mode(value: str, device_type: str, world: int) -> str:
    """rvn-train's train.compile_mode as torch.compile takes it. ``auto``: reduce-overhead on one CUDA device (each
    compiled part's forward and backward replayed as CUDA graphs: NoMaD full x2.6 and ViNT x2.1 the compiled default
    step on an H200, docs/results/2026-11-27_gpu3; the same losses and checkpoint as the plain fp32 step there,
    tests/test_compiled.py, passed on 2026-12-04), default elsewhere: on a CPU the two compile alike, and with several
    ranks (DDP) CUDA graphs have not been tested."""
    if value != "auto":
        return value
    return "reduce-overhead" if device_type == "cuda" and world == 1 else "default"


def fused_on(device) -> bool | None:
    """Adam's and AdamW's ``fused`` for the torch device ``device``: on CUDA one kernel a step for every parameter
    (rvn-train's AdamW, rvn-rl's Adam: host-bound steps on a GPU node, docs/results/2026-12-04_gpu4); elsewhere
    torch's default (None: the for-each or per-tensor step)."""
    return True if getattr(device, "type", None) == "cuda" else None


def load_optimizer_state(optimizer, state: dict, device) -> None:
    """``optimizer`` resumed from ``state`` (its saved `state_dict`), stepping as ``device``'s runs do: the saved
    groups carry the saving run's ``fused`` (a GPU run's True), which would otherwise carry over to this device."""
    optimizer.load_state_dict(state)
    for group in optimizer.param_groups:
        group["fused"] = fused_on(device)


def check_precision_on(value: str, device) -> None:
    """train.precision=bf16 on a CUDA GPU without bfloat16 (before Ampere) would fail inside autocast at the first
    step: a one-line ValueError naming the GPU instead. CPUs run bf16 (emulated where they lack it: slow, not wrong)."""
    if value == "bf16" and getattr(device, "type", None) == "cuda":
        import torch

        if not torch.cuda.is_bf16_supported():
            raise ValueError(f"train.precision=bf16: {torch.cuda.get_device_name(device)} has no bfloat16 "
                             "(GPUs from Ampere on); use train.precision=fp32")
