"""NoMaD's fast sampling path against the reference one: the packed U-Net against the module's
forward, the precomputed DDPM and DDIM updates against diffusers' DDPMScheduler.step and
DDIMScheduler.step, and whole ``predict`` calls, for every prediction_type and sampler, with the
same seeded generator; the policies' decision thread cap."""
from __future__ import annotations

import numpy as np
import pytest
import torch

from rvn_data.conventions import AgentConfig
from rvn_il.models import build_model, load_model_config
from rvn_il.models.nomad import PREDICTION_TYPES, SAMPLERS
from rvn_il.models.sampling_plan import NoiseSchedule, coefficient_update, ddim_plan, ddpm_plan, plan_coefficients
from rvn_il.policies import ControlConfig, Member, PointGoalPolicy

torch.set_num_threads(1)


def nomad(size: str = "small", **overrides):
    torch.manual_seed(0)
    return build_model(load_model_config("nomad_pointgoal", size, **overrides)).eval()


def inputs(model, b: int = 2):
    g = torch.Generator().manual_seed(5)
    tokens = torch.randn(b, model.context_size + 1, model.encoding_size, generator=g)
    return tokens, torch.randn(b, 2, generator=g) * 3


@pytest.mark.parametrize("prediction_type", PREDICTION_TYPES)
def test_ddpm_plan_matches_diffusers_step(prediction_type):
    """The same denoiser outputs through both updates (noise from generators seeded alike) give
    the same floats."""
    model = nomad(prediction_type=prediction_type)
    plan = ddpm_plan(model.noise_schedule, model.num_diffusion_iters)
    model.scheduler.set_timesteps(model.num_diffusion_iters)
    assert [s.t for s in plan] == model.scheduler.timesteps.tolist()
    cond = torch.randn(16, model.encoding_size)
    ga, gb = torch.Generator().manual_seed(3), torch.Generator().manual_seed(3)
    xa = xb = torch.randn(16, model.len_traj_pred, 2, generator=torch.Generator().manual_seed(1))
    with torch.no_grad():
        for step in plan:
            out_a = model.noise_pred_net(xa, step.t, cond)
            xa = model.scheduler.step(out_a, step.t, xa, generator=ga).prev_sample
            xb = step.update(model.noise_pred_net(xb, step.t, cond), xb, gb)
            torch.testing.assert_close(xb, xa, rtol=0, atol=0)  # the same float operations
    assert torch.equal(ga.get_state(), gb.get_state())  # the same number of draws


@pytest.mark.parametrize("prediction_type", PREDICTION_TYPES)
def test_ddim_plan_matches_diffusers_step(prediction_type):
    """DDIM (eta 0): the same floats as diffusers' DDIMScheduler.step over the same timesteps, and
    no noise drawn after the initial one."""
    from diffusers import DDIMScheduler

    model = nomad(prediction_type=prediction_type)
    ddim = DDIMScheduler.from_config(model.scheduler.config)
    ddim.set_timesteps(model.num_diffusion_iters)
    plan = ddim_plan(model.noise_schedule, model.num_diffusion_iters)
    assert [s.t for s in plan] == ddim.timesteps.tolist() == list(range(9, -1, -1))
    cond = torch.randn(16, model.encoding_size)
    ga, gb = torch.Generator().manual_seed(3), torch.Generator().manual_seed(3)
    xa = xb = torch.randn(16, model.len_traj_pred, 2, generator=torch.Generator().manual_seed(1))
    with torch.no_grad():
        for step in plan:
            xa = ddim.step(model.noise_pred_net(xa, step.t, cond), step.t, xa, generator=ga).prev_sample
            xb = step.update(model.noise_pred_net(xb, step.t, cond), xb, gb)
            torch.testing.assert_close(xb, xa, rtol=0, atol=0)
    assert torch.equal(ga.get_state(), torch.Generator().manual_seed(3).get_state())  # eta 0: no draws


@pytest.mark.parametrize("prediction_type", PREDICTION_TYPES)
@pytest.mark.parametrize("make_plan", [ddpm_plan, ddim_plan])
@pytest.mark.parametrize("clip", [1.0, None])
def test_coefficient_update_is_the_steps_update(make_plan, prediction_type, clip):
    """The compiled CPU sampler's update (one graph for every step: the step's numbers a row of a tensor, the noise
    always added, zeros where a DDPM step draws none) gives each plan step's own update, the same floats."""
    plan = make_plan(NoiseSchedule(100, prediction_type, clip), 10)
    rows = plan_coefficients(plan)
    assert rows.shape == (10, 5) and rows.dtype == torch.float32
    g = torch.Generator().manual_seed(0)
    x = torch.randn(8, 8, 2, generator=g)
    for step, row in zip(plan, rows):
        out, noise = torch.randn(8, 8, 2, generator=g), torch.randn(8, 8, 2, generator=g)
        given = noise if step.std else torch.zeros_like(x)
        ours = coefficient_update(plan[0], row, out, x, given)  # the plan's first step: kind, prediction type, clip
        assert torch.equal(ours, step.update(out, x, noise=noise)), step
        x = ours


@pytest.mark.parametrize("num_train, num_steps", [(10, 10), (2, 2), (16, 16), (100, 100), (100, 10), (10, 3)])
def test_noise_schedule_gives_diffusers_numbers(num_train, num_steps):
    """The plans' noise schedule, computed without importing diffusers, gives its DDPMScheduler's and DDIMScheduler's
    ᾱ and inference timesteps, the same floats and integers, for other step counts than NoMaD's 10 too."""
    from diffusers import DDIMScheduler, DDPMScheduler

    for kind in PREDICTION_TYPES:
        ours = NoiseSchedule(num_train, kind)
        ddpm = DDPMScheduler(num_train_timesteps=num_train, beta_schedule="squaredcos_cap_v2", clip_sample=True,
                             prediction_type=kind)
        ddim = DDIMScheduler.from_config(ddpm.config)
        for ref in (ddpm, ddim):
            assert torch.equal(ours.alphas_cumprod(), ref.alphas_cumprod)
            ref.set_timesteps(num_steps)
            assert ours.timesteps(num_steps) == ref.timesteps.tolist()
    with pytest.raises(ValueError, match="11 inference steps for a schedule of 10 timesteps"):
        NoiseSchedule(10, "epsilon").timesteps(11)


@pytest.mark.parametrize("size", ["small", "full"])
def test_packed_unet_matches_forward(size):
    model = nomad(size)
    net = model.noise_pred_net
    g = torch.Generator().manual_seed(2)
    x = torch.randn(6, model.len_traj_pred, 2, generator=g)
    cond = torch.randn(6, model.encoding_size, generator=g)
    t = torch.tensor([9, 7, 5, 3, 1, 0])
    with torch.no_grad():
        biases = net.film_biases(t, cond)
        torch.testing.assert_close(net.forward_packed(x, biases), net(x, t, cond), rtol=0, atol=1e-5)
        steps = torch.arange(9, -1, -1)
        packed = net.packed_film_biases(steps, cond[:2], net.packed_weights())
        for k, s in enumerate(steps.tolist()):
            for got, want in zip(packed[k], net.film_biases(s, cond[:2])):
                torch.testing.assert_close(got, want, rtol=0, atol=1e-5)


def test_packed_weights_follow_parameter_changes():
    """The repacked weights are cached, and rebuilt after an in-place change or a load."""
    model, other = nomad(), nomad()
    with torch.no_grad():
        for p in other.parameters():
            p.add_(0.01 * torch.randn_like(p))
    net = model.noise_pred_net
    x = torch.randn(4, model.len_traj_pred, 2)
    cond = torch.randn(4, model.encoding_size)
    t = torch.tensor([9, 5, 2, 0])
    with torch.no_grad():
        assert net.packed_weights() is net.packed_weights()
        model.load_state_dict(other.state_dict())
        torch.testing.assert_close(net.forward_packed(x, net.film_biases(t, cond)), other.noise_pred_net(x, t, cond),
                                   rtol=0, atol=1e-5)
        net.final_conv[1].bias.add_(1.0)
        torch.testing.assert_close(net.forward_packed(x, net.film_biases(t, cond)), net(x, t, cond), rtol=0, atol=1e-5)


@pytest.mark.parametrize("sampler", SAMPLERS)
@pytest.mark.parametrize("prediction_type", PREDICTION_TYPES)
def test_predict_fast_matches_reference_path(prediction_type, sampler):
    model = nomad(prediction_type=prediction_type)
    model.sampler = sampler
    tokens, goal = inputs(model)
    mask = torch.tensor([0.0, 1.0])
    ref = model.predict(tokens, goal, 8, torch.Generator().manual_seed(7), mask, fast=False)
    fast = model.predict(tokens, goal, 8, torch.Generator().manual_seed(7), mask)
    assert fast.shape == (2, 8, model.len_traj_pred, 2)
    # the updates match diffusers exactly (tests above); what differs is the packed U-Net's float rounding
    # (~1e-6), which DDIM carries into x_{t-1} through its epsilon term undamped, then the cumsum of 8 deltas
    torch.testing.assert_close(fast, ref, rtol=0, atol=1e-5 if sampler == "ddpm" else 1e-4)
    torch.testing.assert_close(model.predict(tokens, goal, 8, torch.Generator().manual_seed(7), mask), fast,
                               rtol=0, atol=0)  # deterministic for a seed


def test_ddim_samples_depend_only_on_the_initial_noise():
    """With DDIM a sample is a function of its starting noise: after the initial draw the generator
    is left as it was, and the samples differ from DDPM's from the same start."""
    model = nomad(prediction_type="sample")
    tokens, goal = inputs(model, 1)
    g = torch.Generator().manual_seed(9)
    model.sampler = "ddim"
    ddim = model.predict(tokens, goal, 8, g)
    after_start = torch.Generator().manual_seed(9)
    torch.randn((8, model.len_traj_pred, 2), generator=after_start)
    assert torch.equal(g.get_state(), after_start.get_state())
    model.sampler = "ddpm"
    assert not torch.allclose(model.predict(tokens, goal, 8, torch.Generator().manual_seed(9)), ddim)
    model.sampler = "heun"
    with pytest.raises(ValueError, match="policy.sampler='heun'; choose one of ddpm, ddim"):
        model.predict(tokens, goal, 8, g)


def test_predict_full_size_one_item():
    """The policy's case: one item, full size."""
    model = nomad("full")
    tokens, goal = inputs(model, 1)
    fast = model.predict(tokens, goal, 8, torch.Generator().manual_seed(4))
    ref = model.predict(tokens, goal, 8, torch.Generator().manual_seed(4), fast=False)
    torch.testing.assert_close(fast, ref, rtol=0, atol=1e-5)


@pytest.mark.parametrize("threads, inside", [(1, 1), (None, 2)])
def test_policy_decision_threads(threads, inside):
    """A decision runs with at most ``threads`` intra-op threads; torch's setting is restored."""
    model = nomad()
    seen = []
    encode = model.encode_frames
    model.encode_frames = lambda x, **kw: seen.append(torch.get_num_threads()) or encode(x, **kw)
    policy = PointGoalPolicy([Member(model, 0.25)], ControlConfig.from_agent(AgentConfig()), 2, threads=threads)
    before = torch.get_num_threads()
    torch.set_num_threads(2)
    try:
        policy.act({"rgb": np.zeros((64, 64, 3), np.uint8), "pointgoal": np.array([2.0, 0.5], np.float32)})
        assert seen == [inside] and torch.get_num_threads() == 2
    finally:
        torch.set_num_threads(before)
    with pytest.raises(ValueError, match="policy threads=0"):
        PointGoalPolicy([Member(model, 0.25)], ControlConfig.from_agent(AgentConfig()), threads=0)


def test_fast_policy_acts_as_the_reference_path():
    """A NoMaD full policy's decisions with the inference forms (the packed encoder and U-Net, the precomputed
    updates) and on the reference path (the modules' forward, diffusers' scheduler), same weights and seed, over a
    walk of frames: the same action every step and the followed trajectories equal to float rounding."""
    from rvn_il.data.synthetic import render_frame

    policies = []
    for fast in (True, False):
        model = nomad("full")
        model.fast_sampling = model.fast_encoding = fast
        policies.append(PointGoalPolicy([Member(model, 0.25)], ControlConfig.from_agent(AgentConfig()), 8, threads=1))
    frames = [render_frame(np.array([0.2 * k, 0.05 * k]), 0.1 * k, 128) for k in range(12)]
    actions = {True: [], False: []}
    for policy, fast in zip(policies, (True, False)):
        policy.reset()
        for k, rgb in enumerate(frames):
            goal = np.array([3.0 - 0.2 * k, 1.0 - 0.3 * k], np.float32)
            actions[fast].append((policy.act({"rgb": rgb, "pointgoal": goal}), policy.last_waypoints.copy()))
    for (fast_action, fast_wp), (ref_action, ref_wp) in zip(actions[True], actions[False]):
        assert fast_action == ref_action
        np.testing.assert_allclose(fast_wp, ref_wp, rtol=0, atol=1e-4)
    assert len({a for a, _ in actions[True]}) > 1  # the walk asks for more than one action
