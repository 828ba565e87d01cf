"""The depth model: a small U-Net that maps one RGB frame to metric depth, its checkpoint
(``model.safetensors`` + ``model.json``) and the frozen predictor the RL side calls.

`DepthNet`: encoder of stride-2 conv blocks (``widths``; input RGB plus two pixel-coordinate
channels, since a fixed-height, level camera ties image rows to floor distance), a global
context vector added at the bottleneck (scale needs the whole view), a decoder of bilinear
up-sampling + skip concatenation, and a head predicting log depth at half resolution,
up-sampled to the input size. The output is metres (not relative depth): the robot needs
metric depth, so the training loss has a scale-dependent term.

`load_depth_model(path)` -> `DepthPredictor`: ``predictor(rgb uint8 [N,H,W,3]) -> depth
float32 [N,H,W]`` metres, in eval mode under ``torch.no_grad`` (on a CPU with 1 torch thread
unless told otherwise: several threads on a loaded, shared CPU can be far slower); frames of another size than
the training ``image_size`` are area-resized to it and the depth resized back (bilinear).
"""
from __future__ import annotations

import hashlib
import json
import math
from pathlib import Path

import numpy as np
import torch
import torch.nn.functional as F
from torch import nn

from rvn_data.atomic import write_bytes_atomic, write_text_atomic

from .settings import DepthModelSettings

DEFAULTS = DepthModelSettings()  # the ``model`` group's defaults and range rules (one place: settings.py)
WEIGHTS, CONFIG = "model.safetensors", "model.json"
KIND = "rvn_rl.depth"


def conv_block(cin: int, cout: int, stride: int) -> nn.Sequential:
    return nn.Sequential(
        nn.Conv2d(cin, cout, 3, stride=stride, padding=1, bias=False), nn.BatchNorm2d(cout), nn.ReLU(inplace=True),
        nn.Conv2d(cout, cout, 3, padding=1, bias=False), nn.BatchNorm2d(cout), nn.ReLU(inplace=True))


class DepthNet(nn.Module):
    """RGB float [N,3,H,W] in [0,1] -> log depth [N,H,W] (metres), clamped to [min_depth, max_depth]."""

    def __init__(self, widths=tuple(DEFAULTS.widths), min_depth: float = DEFAULTS.min_depth,
                 max_depth: float = DEFAULTS.max_depth, init_depth: float = 2.0):
        super().__init__()
        widths = [int(w) for w in widths]
        DepthModelSettings(widths, min_depth, max_depth)  # its range rules: one line naming the setting
        self.config = {"widths": widths, "min_depth": float(min_depth), "max_depth": float(max_depth)}
        cin, self.down = 5, nn.ModuleList()
        for w in widths:
            self.down.append(conv_block(cin, w, stride=2))
            cin = w
        self.context = nn.Linear(widths[-1], widths[-1])
        self.up = nn.ModuleList(conv_block(widths[i + 1] + widths[i], widths[i], stride=1)
                                for i in reversed(range(len(widths) - 1)))
        self.head = nn.Conv2d(widths[0], 1, 3, padding=1)
        nn.init.zeros_(self.head.weight)  # start from a constant depth: the training set's median
        nn.init.constant_(self.head.bias, math.log(min(max(init_depth, min_depth), max_depth)))

    @staticmethod
    def _coords(x: torch.Tensor) -> torch.Tensor:
        n, _, h, w = x.shape
        ys = torch.linspace(-1.0, 1.0, h, device=x.device, dtype=x.dtype).view(1, 1, h, 1).expand(n, 1, h, w)
        xs = torch.linspace(-1.0, 1.0, w, device=x.device, dtype=x.dtype).view(1, 1, 1, w).expand(n, 1, h, w)
        return torch.cat([ys, xs], 1)

    def forward(self, rgb: torch.Tensor) -> torch.Tensor:
        size = rgb.shape[-2:]
        x = torch.cat([(rgb - 0.5) / 0.25, self._coords(rgb)], 1)
        skips = []
        for block in self.down:
            x = block(x)
            skips.append(x)
        x = x + self.context(x.mean((2, 3)))[:, :, None, None]
        for i, block in enumerate(self.up):
            skip = skips[-2 - i]
            x = F.interpolate(x, size=skip.shape[-2:], mode="bilinear", align_corners=False)
            x = block(torch.cat([x, skip], 1))
        x = F.interpolate(self.head(x), size=size, mode="bilinear", align_corners=False)[:, 0]
        return x.clamp(math.log(self.config["min_depth"]), math.log(self.config["max_depth"]))


def to_input(rgb: np.ndarray | torch.Tensor, device="cpu") -> torch.Tensor:
    """uint8 [N,H,W,3] -> float [N,3,H,W] in [0,1]."""
    t = torch.as_tensor(np.asarray(rgb) if not isinstance(rgb, torch.Tensor) else rgb, device=device)
    return t.permute(0, 3, 1, 2).float().div_(255.0)


class DepthPredictor:
    """A frozen `DepthNet`: ``predictor(rgb uint8 [N,H,W,3]) -> depth float32 [N,H,W]`` metres."""

    def __init__(self, net: DepthNet, image_size: int, device: str | torch.device = "cpu", info: dict | None = None,
                 threads: int | None = 1, folder: str | Path | None = None):
        if threads is not None and (isinstance(threads, bool) or not isinstance(threads, int) or threads < 1):
            raise ValueError(f"depth model threads={threads!r}; give a positive integer or null (torch's setting)")
        self.net = net.to(device).eval().requires_grad_(False)
        self.image_size, self.device, self.info = int(image_size), torch.device(device), dict(info or {})
        self.threads = threads
        self.folder = None if folder is None else Path(folder)  # where `load_depth_model` read it (None: built here)

    def __call__(self, rgb) -> np.ndarray:
        rgb = np.asarray(rgb)
        if rgb.dtype != np.uint8 or rgb.ndim != 4 or rgb.shape[-1] != 3:
            raise ValueError(f"depth model input must be uint8 [N,H,W,3] RGB, got {rgb.dtype} {list(rgb.shape)}")
        if self.threads is None or self.device.type != "cpu":
            return self._predict(rgb)
        old = torch.get_num_threads()
        torch.set_num_threads(self.threads)
        try:
            return self._predict(rgb)
        finally:
            torch.set_num_threads(old)

    def _predict(self, rgb: np.ndarray) -> np.ndarray:
        x = to_input(rgb, self.device)
        size, s = x.shape[-2:], self.image_size
        with torch.no_grad():
            if tuple(size) != (s, s):
                x = F.interpolate(x, size=(s, s), mode="area")
            depth = self.net(x).exp_()
            if tuple(size) != (s, s):
                depth = F.interpolate(depth[:, None], size=tuple(size), mode="bilinear", align_corners=False)[:, 0]
        return depth.float().cpu().numpy()


def weights_digest(data: bytes) -> str:
    """The digest of a ``model.safetensors``'s bytes that ``model.json`` records (``weights_sha256``)."""
    return hashlib.sha256(data).hexdigest()[:16]


def model_folder(path: str | Path) -> Path:
    """The folder of a depth model given as the folder or as its ``model.safetensors``."""
    path = Path(path).expanduser()
    return path if path.is_dir() else path.parent


def model_digest(path: str | Path) -> str:
    """Digest (sha256, 16 hex digits) of a depth model's ``model.json`` and ``model.safetensors`` (``path``: the
    folder or its ``model.safetensors``, as `load_depth_model` takes): what an rvn-rl run records as
    ``depth.model_digest``, so that a run is not resumed on another depth model."""
    folder = model_folder(path)
    h = hashlib.sha256()
    for name in (CONFIG, WEIGHTS):
        f = folder / name
        if not f.is_file():
            raise ValueError(f"depth model {path}: {name} not found; give the out_dir of python -m rvn_rl.depth.cli")
        h.update(name.encode() + b"\0" + f.read_bytes())
    return h.hexdigest()[:16]


def save_depth_model(net: DepthNet, out_dir: str | Path, image_size: int, extra: dict | None = None) -> Path:
    """Write ``model.json`` and then ``model.safetensors`` (each atomic) into ``out_dir``; model.json records the
    weights' digest (``weights_sha256``), so a save cut off between the two (or one file replaced alone) leaves a pair
    that `load_depth_model` refuses rather than weights of another model under this one's model.json."""
    from safetensors.torch import save

    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    state = {k: v.detach().cpu().contiguous() for k, v in net.state_dict().items()}
    data = save(state)
    meta = {"kind": KIND, "model": net.config, "image_size": int(image_size), "weights_sha256": weights_digest(data),
            **(extra or {})}
    write_text_atomic(out_dir / CONFIG, json.dumps(meta, indent=2) + "\n")
    write_bytes_atomic(out_dir / WEIGHTS, data)
    return out_dir / WEIGHTS


def load_depth_model(path: str | Path, device: str | torch.device = "cpu", threads: int | None = 1) -> DepthPredictor:
    """The frozen predictor of a depth checkpoint: a folder holding ``model.safetensors`` and
    ``model.json`` (the CLI's ``out_dir``), or the ``model.safetensors`` file itself. On a
    CPU each call runs with at most ``threads`` torch threads (default 1, as the IL policies;
    None: torch's setting), restored afterwards."""
    from safetensors.torch import load

    folder = model_folder(path)
    weights, config = folder / WEIGHTS, folder / CONFIG
    for f in (weights, config):
        if not f.is_file():
            raise ValueError(f"depth model {path}: {f.name} not found; train one with python -m rvn_rl.depth.cli")
    try:
        meta = json.loads(config.read_text())
    except ValueError as e:
        raise ValueError(f"depth model {config}: not valid JSON ({e})") from None
    if meta.get("kind") != KIND:
        raise ValueError(f"depth model {config}: kind={meta.get('kind')!r}, expected {KIND!r} (not a depth checkpoint)")
    data = weights.read_bytes()
    recorded = meta.get("weights_sha256")  # absent in models saved before it was recorded
    if recorded is not None and recorded != weights_digest(data):
        raise ValueError(f"depth model {folder}: {WEIGHTS} is not the one {CONFIG} was saved with (digest "
                         f"{weights_digest(data)}, recorded {recorded}: a save cut off or one file replaced); train "
                         "the model again or copy both files together")
    net = DepthNet(**meta["model"])
    try:
        net.load_state_dict(load(data))
    except (RuntimeError, OSError) as e:
        raise ValueError(f"depth model {weights}: weights do not fit model.json ({str(e).splitlines()[0]})") from None
    return DepthPredictor(net, meta["image_size"], device, info=meta, threads=threads, folder=folder)
