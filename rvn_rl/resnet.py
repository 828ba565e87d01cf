"""ResNets with GroupNorm and a configurable base width, as habitat-baselines' DD-PPO
(`habitat_baselines/rl/ddppo/policy/resnet.py`): stem 7x7/2 + max-pool, four stages,
spatial compression 1/32. ``resnet50`` with ``base_planes=32`` is the half-width ResNet-50
of DD-PPO PointNav; ``resnet18`` is the light variant for CPU runs."""
from __future__ import annotations

from torch import nn


def conv3x3(cin: int, cout: int, stride: int = 1) -> nn.Conv2d:
    return nn.Conv2d(cin, cout, kernel_size=3, stride=stride, padding=1, bias=False)


class BasicBlock(nn.Module):
    expansion = 1

    def __init__(self, cin: int, planes: int, ngroups: int, stride: int = 1, downsample: nn.Module | None = None):
        super().__init__()
        self.convs = nn.Sequential(
            conv3x3(cin, planes, stride), nn.GroupNorm(ngroups, planes), nn.ReLU(True),
            conv3x3(planes, planes), nn.GroupNorm(ngroups, planes))
        self.downsample = downsample
        self.relu = nn.ReLU(True)

    def forward(self, x):
        residual = x if self.downsample is None else self.downsample(x)
        return self.relu(self.convs(x) + residual)


class Bottleneck(nn.Module):
    expansion = 4

    def __init__(self, cin: int, planes: int, ngroups: int, stride: int = 1, downsample: nn.Module | None = None):
        super().__init__()
        out = planes * self.expansion
        self.convs = nn.Sequential(
            nn.Conv2d(cin, planes, kernel_size=1, bias=False), nn.GroupNorm(ngroups, planes), nn.ReLU(True),
            conv3x3(planes, planes, stride), nn.GroupNorm(ngroups, planes), nn.ReLU(True),
            nn.Conv2d(planes, out, kernel_size=1, bias=False), nn.GroupNorm(ngroups, out))
        self.downsample = downsample
        self.relu = nn.ReLU(True)

    def forward(self, x):
        residual = x if self.downsample is None else self.downsample(x)
        return self.relu(self.convs(x) + residual)


class ResNet(nn.Module):
    final_spatial_compress = 1.0 / 32

    def __init__(self, in_channels: int, base_planes: int, ngroups: int, block, layers: list[int]):
        super().__init__()
        self.conv1 = nn.Sequential(
            nn.Conv2d(in_channels, base_planes, kernel_size=7, stride=2, padding=3, bias=False),
            nn.GroupNorm(ngroups, base_planes), nn.ReLU(True))
        self.maxpool = nn.MaxPool2d(kernel_size=3, stride=2, padding=1)
        self.inplanes = base_planes
        stages = []
        for i, n in enumerate(layers):
            stages.append(self._make_layer(block, ngroups, base_planes * 2 ** i, n, stride=1 if i == 0 else 2))
        self.layer1, self.layer2, self.layer3, self.layer4 = stages
        self.final_channels = self.inplanes

    def _make_layer(self, block, ngroups: int, planes: int, blocks: int, stride: int) -> nn.Sequential:
        downsample = None
        if stride != 1 or self.inplanes != planes * block.expansion:
            downsample = nn.Sequential(
                nn.Conv2d(self.inplanes, planes * block.expansion, kernel_size=1, stride=stride, bias=False),
                nn.GroupNorm(ngroups, planes * block.expansion))
        layers = [block(self.inplanes, planes, ngroups, stride, downsample)]
        self.inplanes = planes * block.expansion
        layers += [block(self.inplanes, planes, ngroups) for _ in range(1, blocks)]
        return nn.Sequential(*layers)

    def forward(self, x):
        x = self.maxpool(self.conv1(x))
        return self.layer4(self.layer3(self.layer2(self.layer1(x))))


BACKBONES = {"resnet18": (BasicBlock, [2, 2, 2, 2]), "resnet50": (Bottleneck, [3, 4, 6, 3])}


def make_backbone(name: str, in_channels: int, base_planes: int, ngroups: int) -> ResNet:
    if name not in BACKBONES:
        raise ValueError(f"model.backbone={name!r}: choose one of {sorted(BACKBONES)}")
    block, layers = BACKBONES[name]
    return ResNet(in_channels, base_planes, ngroups, block, layers)
