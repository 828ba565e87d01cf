"""The monocular depth model of the DD-PPO + predicted depth baseline (in place of the
paper's frozen Depth Anything V2): a small U-Net trained on rendered (RGB, exact depth)
pairs of train scenes and evaluated on val scenes (``python -m rvn_rl.depth.cli``).

``load_depth_model(path, device="cpu")(rgb uint8 [N,H,W,3]) -> depth float32 [N,H,W]`` metres
(frozen, eval mode, no gradients); ``path`` is the CLI's ``out_dir`` or its ``model.safetensors``.
"""
from .model import DepthNet, DepthPredictor, load_depth_model, save_depth_model

__all__ = ["DepthNet", "DepthPredictor", "load_depth_model", "save_depth_model"]
