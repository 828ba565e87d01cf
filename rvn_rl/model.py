"""`PointNavResNetPolicy` of habitat-baselines' DD-PPO PointNav: a GroupNorm ResNet on the
(optionally average-pooled, running mean/var normalised) RGB(-D) frame, compressed to 2048
features and a 512-d layer, a 32-d previous-action embedding, a 32-d embedding of the goal
as (rho, cos(-phi), sin(-phi)), a 2-layer LSTM (hidden 512), an actor, a critic and, for
PPO-Lagrangian, a cost critic. Recurrent state is reset where ``masks`` is 0. With ``autocast_bf16`` set (rvn-rl's
``train.precision=bf16``) the visual encoder and its layer run under torch.autocast(bfloat16), the rest in float32;
``compile_visual`` (``train.compile``) compiles the visual trunk."""
from __future__ import annotations

import contextlib
import math

import torch
import torch.distributed as dist
import torch.nn.functional as F
from torch import nn

from .recurrent import Pieces, run_lstm
from .resnet import make_backbone

NUM_ACTIONS = 4
DEPTH_MAX = 10.0  # m: depth is clipped to [0, DEPTH_MAX] and scaled to [0, 1], as Habitat's depth sensor


class RunningMeanAndVar(nn.Module):
    """Per-channel running mean/variance of the visual input (updated in training mode only,
    averaged over ranks when torch.distributed is initialised)."""

    def __init__(self, channels: int):
        super().__init__()
        self.register_buffer("_mean", torch.zeros(1, channels, 1, 1))
        self.register_buffer("_var", torch.zeros(1, channels, 1, 1))
        self.register_buffer("_count", torch.zeros(()))

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        if self.training:
            flat = x.detach().transpose(0, 1).reshape(x.size(1), -1)
            mean = flat.mean(-1)
            count = torch.full_like(self._count, x.size(0))
            world = dist.get_world_size() if dist.is_available() and dist.is_initialized() else 1
            if world > 1:
                dist.all_reduce(mean)
                dist.all_reduce(count)
                mean /= world
            var = (flat - mean[:, None]).pow(2).mean(-1)
            if world > 1:
                dist.all_reduce(var)
                var /= world
            mean, var = mean.view(1, -1, 1, 1), var.view(1, -1, 1, 1)
            delta = mean - self._mean
            total = self._count + count
            m2 = self._var * self._count + var * count + delta.pow(2) * self._count * count / total
            self._mean.copy_(self._mean + delta * count / total)
            self._var.copy_(m2 / total)
            self._count.copy_(total)
        inv_std = torch.rsqrt(torch.clamp(self._var, min=1e-2))
        return torch.addcmul(-self._mean * inv_std, x, inv_std)


class ResNetEncoder(nn.Module):
    def __init__(self, backbone: str, in_channels: int, obs_size: int, input_size: int, base_planes: int,
                 ngroups: int, flat_size: int = 2048):
        super().__init__()
        if obs_size % input_size and obs_size > input_size:
            raise ValueError(f"observation size {obs_size} is not a multiple of model.input_size={input_size}")
        self.pool = max(1, obs_size // input_size)
        side = obs_size // self.pool
        if side < 32:
            raise ValueError(f"observation size {obs_size} (after pooling: {side}) is below 32 pixels; "
                             "set env.size >= 32")
        self.running_mean_and_var = RunningMeanAndVar(in_channels)
        self.backbone = make_backbone(backbone, in_channels, base_planes, ngroups)
        # the ResNet's output side: its five stride-2 layers (stem, max-pool, stages 2-4) each give ceil(side / 2),
        # so ceil(side / 32) (80 px: 3, where int() said 2 and the first forward failed on visual_fc's shape)
        spatial = math.ceil(side * self.backbone.final_spatial_compress)
        channels = int(round(flat_size / spatial ** 2))
        self.compression = nn.Sequential(
            nn.Conv2d(self.backbone.final_channels, channels, kernel_size=3, padding=1, bias=False),
            nn.GroupNorm(1, channels), nn.ReLU(True))
        self.output_size = channels * spatial ** 2

    def normalised(self, x: torch.Tensor) -> torch.Tensor:
        """The frame pooled to the input size and normalised by the running mean and variance."""
        if self.pool > 1:
            x = F.avg_pool2d(x, self.pool)
        return self.running_mean_and_var(x)

    def trunk(self, x: torch.Tensor) -> torch.Tensor:
        """ResNet and compression, flattened (what train.compile compiles, with visual_fc)."""
        return torch.flatten(self.compression(self.backbone(x)), 1)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return self.trunk(self.normalised(x))


def visual_input(obs: dict, use_depth: bool) -> torch.Tensor:
    """float [N, C, H, W]: RGB / 255 (and depth / DEPTH_MAX as a 4th channel)."""
    x = obs["rgb"].permute(0, 3, 1, 2).float() / 255.0
    if use_depth:
        d = obs["depth"].float().clamp(0.0, DEPTH_MAX) / DEPTH_MAX
        x = torch.cat([x, d.unsqueeze(1)], dim=1)
    return x


def goal_input(pointgoal: torch.Tensor) -> torch.Tensor:
    """(rho, cos(-phi), sin(-phi)) of a goal (x forward, y left)."""
    rho = torch.linalg.norm(pointgoal, dim=-1)
    phi = torch.atan2(pointgoal[:, 1], pointgoal[:, 0])
    return torch.stack([rho, torch.cos(-phi), torch.sin(-phi)], dim=-1)


class PointNavResNetPolicy(nn.Module):
    def __init__(self, obs_size: int, backbone: str = "resnet50", base_planes: int = 32, ngroups: int = 16,
                 input_size: int = 128, hidden_size: int = 512, rnn_layers: int = 2, use_depth: bool = False,
                 cost_critic: bool = False):
        super().__init__()
        self.use_depth = use_depth
        self.hidden_size, self.rnn_layers = hidden_size, rnn_layers
        self.visual_encoder = ResNetEncoder(backbone, 4 if use_depth else 3, obs_size, input_size, base_planes, ngroups)
        self.visual_fc = nn.Sequential(nn.Linear(self.visual_encoder.output_size, hidden_size), nn.ReLU(True))
        self.prev_action_embedding = nn.Embedding(NUM_ACTIONS + 1, 32)
        self.goal_embedding = nn.Linear(3, 32)
        self.rnn = nn.LSTM(hidden_size + 64, hidden_size, num_layers=rnn_layers)
        for name, p in self.rnn.named_parameters():
            if "weight" in name:
                nn.init.orthogonal_(p)
            else:
                nn.init.zeros_(p)
        self.actor = self._head(NUM_ACTIONS, 0.01)
        self.critic = self._head(1, 1.0)
        self.cost_critic = self._head(1, 1.0) if cost_critic else None
        # the visual encoder and visual_fc under torch.autocast(bfloat16) (train.precision=bf16): not a weight or an
        # argument, so a checkpoint and its config are the same either way
        self.autocast_bf16 = False
        self._compiled_visual = None  # compile_visual's (train.compile)
        self._cuda_graphs = False

    def compile_visual(self, mode: str = "reduce-overhead") -> None:
        """torch.compile of the visual trunk (ResNet, compression, visual_fc) for every later forward; parameters,
        names and checkpoints are the plain ones. ``mode`` ``reduce-overhead`` replays its forward and backward as CUDA
        graphs on a GPU (each forward then begins a new step for them); on a CPU it compiles as ``default``. The
        running mean and variance stay outside (they update buffers and, in DD-PPO, all-reduce)."""
        cuda = next(self.parameters()).is_cuda
        self._cuda_graphs = cuda and mode == "reduce-overhead"
        self._compiled_visual = torch.compile(self._visual, mode="reduce-overhead" if self._cuda_graphs else None)

    @contextlib.contextmanager
    def eager_visual(self):
        """The visual trunk not compiled while the block runs (`graphed.GraphedAct` records it into a CUDA graph of its
        own, which cannot hold train.compile's)."""
        compiled, self._compiled_visual = self._compiled_visual, None
        try:
            yield
        finally:
            self._compiled_visual = compiled

    def _visual(self, x: torch.Tensor) -> torch.Tensor:
        return self.visual_fc(self.visual_encoder.trunk(x))

    def _head(self, n: int, gain: float) -> nn.Linear:
        head = nn.Linear(self.hidden_size, n)
        nn.init.orthogonal_(head.weight, gain=gain)
        nn.init.zeros_(head.bias)
        return head

    def initial_state(self, n: int, device=None) -> torch.Tensor:
        """Recurrent state [2 * rnn_layers, n, hidden] (LSTM h then c)."""
        return torch.zeros(2 * self.rnn_layers, n, self.hidden_size, device=device)

    def forward(self, obs: dict, state: torch.Tensor, prev_actions: torch.Tensor, masks: torch.Tensor,
                need_state: bool = True, pieces: Pieces | None = None):
        """obs tensors [T*N, ...], state [2L, N, H], prev_actions/masks [T*N] (T steps of N envs,
        time-major). Returns (features [T*N, H], new state); the new state is None with
        ``need_state=False`` when some env starts an episode after step 0, or with ``pieces``, the masks' plan for
        a PPO update (`recurrent.run_lstm`)."""
        n = state.size(1)
        x = visual_input(obs, self.use_depth)
        with torch.autocast(x.device.type, dtype=torch.bfloat16, enabled=self.autocast_bf16):
            # bf16 from a contiguous NCHW frame: GroupNorm's bf16 backward on the channels-last layout that the frame's
            # permute gives took 6x float32's time on a CPU (rvn_rl/README.md, "Precision")
            x = self.visual_encoder.normalised(x.contiguous() if self.autocast_bf16 else x)
            if self._compiled_visual is None:
                visual = self._visual(x)
            else:
                if self._cuda_graphs:  # the last replay's outputs were used: its buffers may be overwritten
                    torch.compiler.cudagraph_mark_step_begin()
                visual = self._compiled_visual(x)
        visual = visual.float()
        prev = self.prev_action_embedding(((prev_actions.long() + 1) * masks.long()))
        x = torch.cat([visual, prev, self.goal_embedding(goal_input(obs["pointgoal"].float()))], dim=-1)
        x = x.view(-1, n, x.size(-1))
        L = self.rnn_layers
        out, h, c = run_lstm(self.rnn, x, masks.float().view(-1, n), state[:L], state[L:], need_state, pieces)
        return out.reshape(-1, self.hidden_size), None if h is None else torch.cat([h, c], 0)

    def act(self, obs, state, prev_actions, masks, deterministic: bool = False, generator=None):
        feats, state = self(obs, state, prev_actions, masks)
        logits = self.actor(feats)
        if deterministic:
            action = logits.argmax(-1)
        else:
            action = torch.multinomial(F.softmax(logits, -1), 1, generator=generator).squeeze(-1)
        logp = F.log_softmax(logits, -1).gather(-1, action[:, None]).squeeze(-1)
        return action, logp, self.values(feats), state

    def values(self, feats: torch.Tensor) -> torch.Tensor:
        """[N, 1] reward value, or [N, 2] reward and cost values with a cost critic."""
        v = self.critic(feats)
        return v if self.cost_critic is None else torch.cat([v, self.cost_critic(feats)], -1)

    def evaluate(self, obs, state, prev_actions, masks, actions, pieces: Pieces | None = None):
        feats, _ = self(obs, state, prev_actions, masks, need_state=False, pieces=pieces)
        logp_all = F.log_softmax(self.actor(feats), -1)
        logp = logp_all.gather(-1, actions.long()[:, None]).squeeze(-1)
        entropy = -(logp_all.exp() * logp_all).sum(-1)
        return logp, entropy, self.values(feats)
