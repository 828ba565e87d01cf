"""The policy's LSTM over rollouts with episode restarts (rvn_rl.recurrent): packed and padded
forms against the definition, one step at a time with the state zeroed where the mask is 0; the PPO update's
plan of pieces (computed on the CPU) against the masks read on the host: the same outputs, gradients and update bit
for bit, and no operation in the learner's pass that makes the host wait for a GPU."""
from __future__ import annotations

import numpy as np
import pytest
import torch
from torch import nn
from torch.utils._python_dispatch import TorchDispatchMode
from torch.utils._pytree import tree_leaves

from rvn_rl.model import PointNavResNetPolicy
from rvn_rl.ppo import PPOConfig, ppo_update
from rvn_rl.recurrent import episode_pieces, plan_pieces, run_lstm
from rvn_rl.rollout import DeviceRollouts, RolloutStorage
from rvn_rl.trainer import _Evaluate


def step_by_step(rnn, x, masks, h, c):
    outs = []
    for t in range(x.size(0)):
        keep = masks[t].view(1, -1, 1)
        out, (h, c) = rnn(x[t:t + 1], (h * keep, c * keep))
        outs.append(out)
    return torch.cat(outs), h, c


def test_episode_pieces_by_hand():
    masks = torch.tensor([[1., 0.], [0., 1.], [1., 1.], [1., 0.]])  # [T=4, N=2]
    env, first, length = episode_pieces(masks)
    assert env.tolist() == [0, 0, 1, 1] and first.tolist() == [0, 1, 0, 3] and length.tolist() == [1, 3, 3, 1]


@pytest.mark.parametrize("T,N,p_restart", [(1, 3, 0.5), (16, 4, 0.2), (40, 2, 0.1), (8, 5, 0.9), (12, 3, 0.0)])
def test_packed_and_padded_match_the_step_by_step_definition(T, N, p_restart):
    g = torch.Generator().manual_seed(T * 10 + N)
    rnn = nn.LSTM(12, 8, num_layers=2)
    x = torch.randn(T, N, 12, generator=g, requires_grad=True)
    masks = (torch.rand(T, N, generator=g) >= p_restart).float()
    masks[-1, 0] = 0.0  # a one-step piece at the end
    h, c = torch.randn(2, N, 8, generator=g), torch.randn(2, N, 8, generator=g)
    ref = step_by_step(rnn, x, masks, h, c)
    packed = run_lstm(rnn, x, masks, h, c)
    padded = run_lstm(rnn, x, masks, h, c, need_state=False)
    for got, want in zip(packed, ref):
        torch.testing.assert_close(got, want, atol=1e-5, rtol=1e-4)
    torch.testing.assert_close(padded[0], ref[0], atol=1e-5, rtol=1e-4)
    if T > 1 and bool((masks[1:] == 0).any()):
        assert padded[1] is None and padded[2] is None
    params = [x, *rnn.parameters()]
    grads_ref = torch.autograd.grad(ref[0].square().sum(), params)
    grads_padded = torch.autograd.grad(padded[0].square().sum(), params)
    for got, want in zip(grads_padded, grads_ref):
        torch.testing.assert_close(got, want, atol=1e-4, rtol=1e-3)


def test_policy_over_a_rollout_equals_its_steps():
    """PointNavResNetPolicy: features of a T-step rollout with restarts (the PPO update's view)
    equal those of the T single-step calls made while collecting it."""
    torch.manual_seed(0)
    net = PointNavResNetPolicy(obs_size=32, backbone="resnet18", base_planes=8, ngroups=4, input_size=32,
                               hidden_size=16).eval()
    T, N = 6, 3
    obs = {"rgb": torch.randint(0, 255, (T * N, 32, 32, 3), dtype=torch.uint8), "pointgoal": torch.randn(T * N, 2)}
    prev = torch.randint(0, 4, (T * N,))
    masks = torch.ones(T * N)
    masks[[0, 4, 2 * N + 1, 4 * N + 1, 5 * N + 2]] = 0.0
    state0 = torch.randn(4, N, 16)
    with torch.no_grad():
        feats, state = net(obs, state0, prev, masks)
        _, loss_view_state = net(obs, state0, prev, masks, need_state=False)
        s, steps = state0, []
        for t in range(T):
            rows = slice(t * N, (t + 1) * N)
            f, s = net({k: v[rows] for k, v in obs.items()}, s, prev[rows], masks[rows])
            steps.append(f)
    torch.testing.assert_close(feats, torch.cat(steps), atol=1e-5, rtol=1e-4)
    torch.testing.assert_close(state, s, atol=1e-5, rtol=1e-4)
    assert loss_view_state is None


@pytest.mark.parametrize("T,N,p_restart", [(1, 3, 0.5), (16, 4, 0.2), (8, 5, 0.9), (12, 3, 0.0)])
def test_a_plan_of_pieces_gives_the_same_pass_bit_for_bit(T, N, p_restart):
    """run_lstm with `plan_pieces` of the masks (a PPO update's mini-batch) against run_lstm reading the masks: the
    same outputs and gradients exactly, with and without restarts after step 0."""
    g = torch.Generator().manual_seed(T * 10 + N)
    rnn = nn.LSTM(12, 8, num_layers=2)
    x = torch.randn(T, N, 12, generator=g, requires_grad=True)
    masks = (torch.rand(T, N, generator=g) >= p_restart).float()
    h, c = torch.randn(2, N, 8, generator=g), torch.randn(2, N, 8, generator=g)
    want = run_lstm(rnn, x, masks, h, c, need_state=False)[0]
    got, h_n, c_n = run_lstm(rnn, x, masks, h, c, need_state=False, pieces=plan_pieces(masks))
    assert torch.equal(got, want) and h_n is None and c_n is None
    params = [x, *rnn.parameters()]
    for a, b in zip(torch.autograd.grad(got.square().sum(), params), torch.autograd.grad(want.square().sum(), params)):
        assert torch.equal(a, b)
    with pytest.raises(ValueError, match="need_state=False"):
        run_lstm(rnn, x, masks, h, c, pieces=plan_pieces(masks))


class HostReads(TorchDispatchMode):
    """The operations that, on a GPU, make the host wait for the device: a value read on the host (``bool()``,
    ``int()``, ``.item()``), ``nonzero`` and ``masked_select`` (their output size), indexing by a boolean mask."""

    def __init__(self):
        super().__init__()
        self.ops = []

    def __torch_dispatch__(self, func, types, args=(), kwargs=None):
        name = str(func.overloadpacket)
        masked = name.startswith("aten.index") and any(
            isinstance(a, torch.Tensor) and a.dtype == torch.bool for a in tree_leaves((args, kwargs or {}))[1:])
        if masked or name in ("aten._local_scalar_dense", "aten.nonzero", "aten.masked_select", "aten.is_nonzero"):
            self.ops.append(name)
        return func(*args, **(kwargs or {}))


def small_update_setup(seed: int = 0, N: int = 4):
    """A small policy, its optimiser and a filled 8-step rollout of ``N`` envs with episode restarts mid-way."""
    torch.manual_seed(seed)
    T, size = 8, 32
    policy = PointNavResNetPolicy(obs_size=size, backbone="resnet18", base_planes=8, ngroups=4, input_size=32,
                                  hidden_size=16)
    rng = np.random.default_rng(seed)

    def obs() -> dict:
        return {"rgb": rng.integers(0, 256, (N, size, size, 3), dtype=np.uint8),
                "pointgoal": rng.normal(size=(N, 2)).astype(np.float32)}

    space = {"rgb": ((size, size, 3), torch.uint8), "pointgoal": ((2,), torch.float32)}
    rollouts = RolloutStorage(T, N, space, tuple(policy.initial_state(N).shape), 1)
    rollouts.set_first(obs(), torch.randn(4, N, 16), torch.zeros(N, dtype=torch.long), torch.ones(N))
    for _ in range(T):
        rollouts.insert(obs(), torch.randint(0, 4, (N,)), torch.randn(N), torch.randn(N, 1), rng.normal(size=(N, 1)),
                        rng.random(N) < 0.3)
    assert bool((rollouts.masks[1:T] == 0).any())  # some env restarts after step 0
    rollouts.compute_returns(torch.randn(N, 1), 0.99, 0.95)
    return policy, torch.optim.Adam(policy.parameters(), lr=1e-3), rollouts


def test_the_learners_pass_reads_nothing_on_the_host():
    """The PPO update's forward + backward on a `DeviceRollouts` mini-batch runs no operation that reads a value on
    the host (`HostReads`); without the mini-batch's plan, the same pass reads the masks (what the check sees)."""
    policy, _, rollouts = small_update_setup()
    learner = _Evaluate(policy)
    adv = rollouts.returns[:rollouts.step, :, 0] - rollouts.values[:rollouts.step, :, 0]
    mb = next(DeviceRollouts(rollouts, "cpu").minibatches(adv, 1, torch.Generator().manual_seed(0)))
    reads = {}
    for plan in (mb["pieces"], None):
        with HostReads() as probe:
            logp, entropy, values = learner(mb["obs"], mb["state"], mb["prev_actions"], mb["masks"], mb["actions"],
                                            pieces=plan)
            (logp.sum() + entropy.sum() + values.sum()).backward()
            nn.utils.clip_grad_norm_(policy.parameters(), 0.5)
        reads[plan is None] = probe.ops
    assert reads[False] == []
    assert "aten.nonzero" in reads[True] and "aten._local_scalar_dense" in reads[True]


class Recording(_Evaluate):
    """The learner, noting whether each call got a plan."""

    def __init__(self, policy):
        super().__init__(policy)
        self.planned = []

    def forward(self, *args, pieces=None):
        self.planned.append(pieces is not None)
        return super().forward(*args, pieces=pieces)


def test_ppo_update_with_plans_equals_the_update_reading_the_masks():
    """Two PPO epochs of 2 mini-batches each, every learner call with its plan: the same losses and the same weights
    bit for bit as without plans (``DeviceRollouts(..., plans=False)``)."""
    cfg = PPOConfig(ppo_epoch=2, num_mini_batch=2)
    results = []
    for plans in (True, False):
        policy, optimizer, rollouts = small_update_setup()
        learner = Recording(policy)
        batches = DeviceRollouts(rollouts, "cpu", plans)
        losses = ppo_update(learner, optimizer, batches, cfg, torch.Generator().manual_seed(1))
        results.append((losses, [p.detach().clone() for p in policy.parameters()], learner.planned))
    (losses, weights, planned), (losses_ref, weights_ref, planned_ref) = results
    assert planned == [True] * 4 and planned_ref == [False] * 4
    assert losses == losses_ref and losses["action_loss"] != 0.0
    assert all(torch.equal(a, b) for a, b in zip(weights, weights_ref))


class Sizes(_Evaluate):
    """The learner, noting how many envs each mini-batch holds."""

    def __init__(self, policy):
        super().__init__(policy)
        self.envs = []

    def forward(self, obs, state, *args, pieces=None):
        self.envs.append(state.size(1))
        return super().forward(obs, state, *args, pieces=pieces)


@pytest.mark.parametrize("n, sizes", [(6, [2, 2, 1, 1]), (10, [3, 3, 2, 2]), (4, [1, 1, 1, 1])])
def test_an_epoch_is_num_mini_batch_mini_batches_at_most_an_env_apart(n, sizes):
    """ppo.num_mini_batch mini-batches an epoch whatever env.num_envs (at least as many: validation), each of whole
    envs, at most one env apart in size, every env in one of them (torch.chunk gave 6 envs in 3 of 2, 10 in 3, 3, 3,
    1)."""
    policy, optimizer, rollouts = small_update_setup(N=n)
    learner = Sizes(policy)
    batches = DeviceRollouts(rollouts, "cpu")
    adv = rollouts.returns[:rollouts.step, :, 0] - rollouts.values[:rollouts.step, :, 0]
    first = rollouts.state0[0, :, 0].tolist()  # random: each env's own, which names it in a mini-batch
    envs = [[first.index(v) for v in mb["state"][0, :, 0].tolist()]
            for mb in batches.minibatches(adv, 4, torch.Generator().manual_seed(0))]
    assert [len(e) for e in envs] == sizes and sorted(sum(envs, [])) == list(range(n))
    ppo_update(learner, optimizer, batches, PPOConfig(ppo_epoch=2, num_mini_batch=4), torch.Generator().manual_seed(1))
    assert learner.envs == sizes * 2
