"""Building blocks shared by ViNT- and NoMaD-PointGoal: the EfficientNet-B0 observation
encoder (ImageNet normalisation inside), the two-layer goal MLP, the sinusoidal positional
encoding and the pre-norm Transformer over the tokens."""
from __future__ import annotations

import math
from pathlib import Path
from typing import Sequence

import torch
from efficientnet_pytorch import EfficientNet
from torch import nn

from .encoder_packed import encode_packed, pack_encoder
from .packing import packed_cache

IMAGENET_MEAN = (0.485, 0.456, 0.406)
IMAGENET_STD = (0.229, 0.224, 0.225)


def replace_bn_with_gn(module: nn.Module, group_size: int = 16) -> nn.Module:
    """Replace every BatchNorm2d by GroupNorm(channels // group_size), as NoMaD does. Where that
    count does not divide the channels (a width_coefficient other than NoMaD's 1.0 or 0.25 can give
    56 channels), the largest group count below it that does, so groups stay whole."""
    for name, child in module.named_children():
        if isinstance(child, nn.BatchNorm2d):
            c = child.num_features
            groups = max(1, c // group_size)
            while c % groups:
                groups -= 1
            setattr(module, name, nn.GroupNorm(groups, c))
        else:
            replace_bn_with_gn(child, group_size)
    return module


def load_imagenet_weights(net: nn.Module, path: str | Path) -> None:
    """Load a local efficientnet-pytorch ImageNet state dict (``.pth`` or ``.safetensors``);
    the classifier, tensors whose shape differs and those the encoder lacks (BatchNorm's running statistics where
    GroupNorm replaced it) are skipped."""
    path = Path(path).expanduser()
    if not path.is_file():
        raise ValueError(f"model.imagenet_weights={path} does not exist (weights are never downloaded; give a local file)")
    if path.suffix == ".safetensors":
        from safetensors.torch import load_file
        state = load_file(str(path))
    else:
        state = torch.load(path, map_location="cpu", weights_only=True)
    own = net.state_dict()
    keep = {k: v for k, v in state.items() if k in own and own[k].shape == v.shape and not k.startswith("_fc")}
    if len(keep) < len([k for k in own if not k.startswith("_fc")]) // 2:
        raise ValueError(f"{path} does not hold EfficientNet-B0 weights matching this encoder (only {len(keep)} tensors match)")
    net.load_state_dict(keep, strict=False)


class ObsEncoder(nn.Module):
    """Images [N,3,H,W] in [0,1] → tokens [N, encoding_size] (EfficientNet-B0 → avg pool → Linear)."""

    def __init__(self, encoding_size: int, image_size: Sequence[int], width_coefficient: float = 1.0,
                 depth_coefficient: float = 1.0, group_norm: bool = False, imagenet_weights: str | None = None):
        super().__init__()
        w, h = int(image_size[0]), int(image_size[1])
        self.net = EfficientNet.from_name("efficientnet-b0", in_channels=3, image_size=[h, w],
                                          width_coefficient=width_coefficient, depth_coefficient=depth_coefficient)
        if group_norm:  # before the weights: GroupNorm takes BatchNorm's scale and shift (its statistics have no use)
            replace_bn_with_gn(self.net)
        if imagenet_weights:
            load_imagenet_weights(self.net, imagenet_weights)
        self.net._fc = nn.Identity()  # unused classifier: keep it out of the parameters
        self.compress = nn.Linear(self.net._conv_head.out_channels, encoding_size)
        self.register_buffer("mean", torch.tensor(IMAGENET_MEAN).view(1, 3, 1, 1), persistent=False)
        self.register_buffer("std", torch.tensor(IMAGENET_STD).view(1, 3, 1, 1), persistent=False)

    def forward(self, images: torch.Tensor) -> torch.Tensor:
        x = self.net.extract_features((images - self.mean) / self.std)
        x = self.net._dropout(self.net._avg_pooling(x).flatten(1))
        return self.compress(x)

    def packed_weights(self) -> dict:
        """The weights of :meth:`forward_packed`, cached until any parameter or buffer changes."""
        return packed_cache(self, lambda: pack_encoder(self))

    def forward_packed(self, images: torch.Tensor) -> torch.Tensor:
        """:meth:`forward` for decisions, in the encoder's inference form (:mod:`.encoder_packed`: channels-last,
        1x1 convolutions as matrix products); the module's ``forward`` while training."""
        if self.training or torch.is_grad_enabled():
            return self(images)
        return encode_packed(self.packed_weights(), images)


class GoalMLP(nn.Sequential):
    """Two-layer MLP on the point goal (x_g, y_g) → a goal token (the paper's goal encoder)."""

    def __init__(self, encoding_size: int):
        super().__init__(nn.Linear(2, encoding_size), nn.ReLU(), nn.Linear(encoding_size, encoding_size))


class PositionalEncoding(nn.Module):
    """Fixed sin/cos encoding added to [B, L, D] tokens."""

    def __init__(self, d_model: int, max_len: int):
        super().__init__()
        pos = torch.arange(max_len).unsqueeze(1)
        div = torch.exp(torch.arange(0, d_model, 2) * (-math.log(10000.0) / d_model))
        pe = torch.zeros(max_len, d_model)
        pe[:, 0::2] = torch.sin(pos * div)
        pe[:, 1::2] = torch.cos(pos * div)[:, : d_model // 2]
        self.register_buffer("pe", pe.unsqueeze(0), persistent=False)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return x + self.pe[:, : x.shape[1]]


class ContextTransformer(nn.TransformerEncoder):
    """``nn.TransformerEncoder`` (same weights and state_dict keys) whose call starts in this file. torch.compile
    does not trace a frame that starts in torch.nn's own files (dynamo's skipfiles), so a compiled
    ``nn.TransformerEncoder`` (``train.compile``) ran eagerly; from this forward it traces torch's code as one graph."""

    def forward(self, src: torch.Tensor, mask: torch.Tensor | None = None,
                src_key_padding_mask: torch.Tensor | None = None, is_causal: bool | None = None) -> torch.Tensor:
        return super().forward(src, mask=mask, src_key_padding_mask=src_key_padding_mask, is_causal=is_causal)


class MLP(nn.Sequential):
    """``nn.Sequential`` whose call starts in this file, so torch.compile traces it (see `ContextTransformer`)."""

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return super().forward(x)


def make_transformer(d_model: int, num_heads: int, num_layers: int, ff_factor: int, dropout: float) -> ContextTransformer:
    """4-layer, 4-head, pre-norm, GELU, batch-first encoder as ViNT/NoMaD."""
    layer = nn.TransformerEncoderLayer(d_model, num_heads, dim_feedforward=ff_factor * d_model, dropout=dropout,
                                       activation="gelu", batch_first=True, norm_first=True)
    return ContextTransformer(layer, num_layers, enable_nested_tensor=False)
