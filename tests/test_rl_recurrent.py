"""The policy's LSTM over rollouts with episode restarts (rvn_rl.recurrent): packed and padded
forms against the definition, one step at a time with the state zeroed where the mask is 0."""
from __future__ import annotations

import pytest
import torch
from torch import nn

from rvn_rl.model import PointNavResNetPolicy
from rvn_rl.recurrent import episode_pieces, run_lstm


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
