"""The observation encoder's inference form (:meth:`~.encoders.ObsEncoder.forward_packed`), as
:meth:`~.unet1d.ConditionalUnet1D.forward_packed` is the denoiser's: the same EfficientNet-B0 function
for a policy's one frame a decision, with channels-last activations throughout, so that

- every 1x1 convolution (expansion, projection, head: 64 of B0's 81 convolutions) is one matrix product
  over the rows [N·H·W, C] with the weight transposed once. On one CPU thread ``nn.Conv2d`` sends a 1x1
  convolution of one image to a GEMM over the channels, which is slow for the small late feature maps:
  192 → 1152 channels at 3x3 took 358 µs, and 75 µs as rows (AVX-512 development CPU);
- the depthwise convolutions read NHWC (oneDNN: 55 against 165 µs for the 96-channel stride-2 one), and
  GroupNorm / BatchNorm read and write channels-last, with no layout copies;
- squeeze-and-excitation is two products on the pooled [N, C].

NoMaD full, one frame of 96x96, one CPU thread: 14.8 ms → 8.6 ms (x1.73, benchmarks/train.py --latency-only);
~7.6 ms once the stride-1 paddings became the convolutions' own. Values agree with the module's forward to
float rounding (tests/test_il_models.py). Eval mode only: drop-connect and dropout are off, BatchNorm (ViNT's
encoder) uses its running statistics."""
from __future__ import annotations

import torch
import torch.nn.functional as F
from torch import nn

CL = torch.channels_last


def _bias(conv: nn.Conv2d) -> torch.Tensor | None:
    return None if conv.bias is None else conv.bias.detach()


def _pack_conv(conv: nn.Conv2d) -> tuple:
    """("rows", weight [C_in, C_out], bias) for a 1x1 stride-1 convolution; otherwise ("conv", channels-last
    weight, bias, stride, groups, static "same" padding or None, padding) of efficientnet-pytorch's padded Conv2d:
    a padding the same on all sides is the convolution's own (F.pad first, then the convolution, took 46-127 µs
    against 34-80 for B0's stride-1 depthwise convolutions at 96x96, with the same values), an uneven one F.pad's."""
    w = conv.weight.detach()
    pad = getattr(conv, "static_padding", None)
    pad = tuple(pad.padding) if isinstance(pad, nn.ZeroPad2d) else None
    if tuple(conv.padding) != (0, 0) or tuple(conv.dilation) != (1, 1):
        raise ValueError(f"forward_packed supports efficientnet-pytorch's static-padding Conv2d only, not {conv}")
    if w.shape[2:] == (1, 1) and conv.groups == 1 and tuple(conv.stride) == (1, 1) and pad is None:
        return "rows", w.flatten(1).t().contiguous(), _bias(conv)
    even = pad is not None and len(set(pad)) == 1  # the same on every side (stride 1): the convolution's own zero padding
    return ("conv", w.contiguous(memory_format=CL), _bias(conv), tuple(conv.stride), conv.groups,
            None if even else pad, pad[0] if even else 0)


def _pack_norm(norm: nn.Module) -> tuple:
    affine = tuple(None if p is None else p.detach() for p in (norm.weight, norm.bias))
    if isinstance(norm, nn.GroupNorm):
        return "group", norm.num_groups, *affine, norm.eps
    if isinstance(norm, nn.BatchNorm2d) and norm.track_running_stats:
        return "batch", norm.running_mean, norm.running_var, *affine, norm.eps
    raise ValueError(f"forward_packed supports GroupNorm and BatchNorm2d with running statistics, not {norm}")


def _pack_linear(conv: nn.Conv2d) -> tuple:
    """A 1x1 convolution on pooled [N, C] (squeeze-and-excitation) as (weight [C_in, C_out], bias)."""
    return conv.weight.detach().flatten(1).t().contiguous(), _bias(conv)


def pack_encoder(encoder: nn.Module) -> dict:
    """:class:`~.encoders.ObsEncoder`'s weights in execution order, for :func:`encode_packed`."""
    net = encoder.net
    blocks = []
    for b in net._blocks:
        args = b._block_args
        blocks.append({
            "expand": (_pack_conv(b._expand_conv), _pack_norm(b._bn0)) if args.expand_ratio != 1 else None,
            "depthwise": (_pack_conv(b._depthwise_conv), _pack_norm(b._bn1)),
            "se": (*_pack_linear(b._se_reduce), *_pack_linear(b._se_expand)) if b.has_se else None,
            "project": (_pack_conv(b._project_conv), _pack_norm(b._bn2)),
            "skip": bool(b.id_skip and args.stride == 1 and args.input_filters == args.output_filters)})
    return {"stem": (_pack_conv(net._conv_stem), _pack_norm(net._bn0)), "blocks": blocks,
            "head": (_pack_conv(net._conv_head), _pack_norm(net._bn1)),
            "compress": (encoder.compress.weight.detach(), encoder.compress.bias.detach()),
            "mean": encoder.mean, "std": encoder.std}


def _conv(x: torch.Tensor, packed: tuple) -> torch.Tensor:
    """A packed convolution of channels-last x [N,C,H,W] → channels-last [N,C',H',W']."""
    if packed[0] == "rows":
        _, w, b = packed
        n, c, h, wd = x.shape
        rows = x.permute(0, 2, 3, 1).reshape(n * h * wd, c)  # a view of channels-last memory
        out = torch.mm(rows, w) if b is None else torch.addmm(b, rows, w)
        return out.view(n, h, wd, -1).permute(0, 3, 1, 2)
    _, w, b, stride, groups, pad, same = packed
    return F.conv2d(x if pad is None else F.pad(x, pad), w, b, stride, same, 1, groups)


def _norm(x: torch.Tensor, packed: tuple, act: bool = True) -> torch.Tensor:
    """The packed norm of x, then swish (in place) when ``act``."""
    if packed[0] == "group":
        y = torch.group_norm(x, *packed[1:])  # without F.group_norm's checks: ~2 µs a call
    else:
        mean, var, w, b, eps = packed[1:]
        y = F.batch_norm(x, mean, var, w, b, False, 0.0, eps)
    return F.silu(y, inplace=True) if act else y


def encode_packed(packed: dict, images: torch.Tensor) -> torch.Tensor:
    """Images [N,3,H,W] in [0, 1] → tokens [N, encoding_size], as ``ObsEncoder.forward`` in eval mode."""
    x = ((images - packed["mean"]) / packed["std"]).contiguous(memory_format=CL)
    conv, norm = packed["stem"]
    x = _norm(_conv(x, conv), norm)
    for blk in packed["blocks"]:
        inputs = x
        if blk["expand"] is not None:
            x = _norm(_conv(x, blk["expand"][0]), blk["expand"][1])
        x = _norm(_conv(x, blk["depthwise"][0]), blk["depthwise"][1])
        if blk["se"] is not None:
            w1, b1, w2, b2 = blk["se"]
            squeezed = F.silu(torch.addmm(b1, x.mean((2, 3)), w1), inplace=True)
            x = x * torch.sigmoid(torch.addmm(b2, squeezed, w2))[:, :, None, None]
        x = _norm(_conv(x, blk["project"][0]), blk["project"][1], act=False)
        if blk["skip"]:
            x = x + inputs
    conv, norm = packed["head"]
    x = _norm(_conv(x, conv), norm)
    return F.linear(x.mean((2, 3)), *packed["compress"])
