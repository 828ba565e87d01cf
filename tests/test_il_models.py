"""ViNT-PointGoal and NoMaD-PointGoal networks (issue 6, models part)."""
from __future__ import annotations

import pytest
import torch

from rvn_il.data import make_dataset
from rvn_il.data.synthetic import write_synthetic_gnm
from rvn_il.models import build_model, load_model_config
from rvn_il.models.checkpoint import load_state_dict_checked, read_weights, save_checkpoint
from rvn_il.models.unet1d import ConditionalUnet1D

torch.set_num_threads(1)


@pytest.fixture(scope="module")
def root(tmp_path_factory):
    return write_synthetic_gnm(tmp_path_factory.mktemp("il_models") / "expert", 3, 24, image_size=64)


@pytest.mark.slow
@pytest.mark.parametrize("name", ["vint_pointgoal", "nomad_pointgoal"])
def test_loss_falls_when_overfitting_8_samples(root, name):
    cfg = load_model_config(name, "small")
    batch = make_dataset(root, cfg, {"progress": False}).get_batch(range(8))
    torch.manual_seed(0)
    model = build_model(cfg)
    opt = torch.optim.AdamW(model.parameters(), lr=1e-3)
    gen = torch.Generator().manual_seed(0)
    losses = []
    for _ in range(30):
        out = model(batch, gen)
        opt.zero_grad()
        out["loss"].backward()
        opt.step()
        losses.append(float(out["loss"].detach()))
    first, last = sum(losses[:5]) / 5, sum(losses[-5:]) / 5
    assert last < 0.7 * first, losses


def test_nomad_actions_normalise_and_goal_mask_hides_goal():
    model = build_model(load_model_config("nomad_pointgoal", "small")).eval()
    wp = torch.tensor([[[1.0, 0.0], [2.0, 0.5], [2.0, 0.5], [2.5, 1.0], [3.0, 1.0], [4.0, 1.0], [5.0, 1.2], [5.0, 1.2]]])
    n = model.normalize_actions(wp)
    assert n.min() >= -1 and n.max() <= 1
    torch.testing.assert_close(model.unnormalize_actions(n), wp)
    tokens = torch.randn(2, 4, model.encoding_size)
    goals = torch.tensor([[3.0, 1.0], [-5.0, 8.0]])
    with torch.inference_mode():
        hidden = model.condition(tokens[:1].expand(2, -1, -1), goals, torch.ones(2))
        seen = model.condition(tokens[:1].expand(2, -1, -1), goals, torch.zeros(2))
        a = model.predict(tokens, goals, 4, torch.Generator().manual_seed(1))
        b = model.predict(tokens, goals, 4, torch.Generator().manual_seed(1))
    torch.testing.assert_close(hidden[0], hidden[1])  # goal hidden: the condition ignores it
    assert not torch.allclose(seen[0], seen[1])
    assert a.shape == (2, 4, 8, 2) and torch.equal(a, b)


def test_unet_film_bias_precompute_matches_plain_forward():
    net = ConditionalUnet1D(2, 16, diffusion_step_embed_dim=32, down_dims=(16, 32, 64)).eval()
    x, cond = torch.randn(5, 8, 2), torch.randn(1, 16)
    with torch.inference_mode():
        plain = net(x, 3, cond.expand(5, -1))
        pre = net(x, biases=net.film_biases(3, cond))
    assert plain.shape == (5, 8, 2)
    torch.testing.assert_close(plain, pre)


def test_vint_predicts_waypoints_and_bad_settings_are_named():
    model = build_model(load_model_config("vint_pointgoal", "small")).eval()
    with torch.inference_mode():
        tokens = model.batch_tokens(torch.rand(2, 6, 3, 64, 64))
        wp = model.predict(tokens, torch.zeros(2, 2))
    assert wp.shape == (2, 1, 5, 2)
    with pytest.raises(ValueError, match="expected context_size"):
        model.batch_tokens(torch.rand(1, 4, 3, 64, 64))
    # the official MultiLayerDecoder: Linear((C+2)*D, D), then the output layers, ReLU after each
    full = build_model(load_model_config("vint_pointgoal", "full"))
    linears = [(m.in_features, m.out_features) for m in full.decoder.modules() if isinstance(m, torch.nn.Linear)]
    assert linears == [(7 * 512, 512), (512, 256), (256, 128), (128, 64), (64, 32)]
    assert sum(isinstance(m, torch.nn.ReLU) for m in full.decoder.modules()) == 5
    old = {k: v for k, v in model.state_dict().items()}  # a checkpoint of the decoder before: one layer less
    old["decoder.2.weight"] = torch.zeros(32, 64)  # 64 -> 32 second, as when 64 came first
    with pytest.raises(ValueError, match="train it again"):
        load_state_dict_checked(model, old, "old")
    with pytest.raises(ValueError, match="imagenet_weights=.*does not exist"):
        build_model(load_model_config("vint_pointgoal", "small", imagenet_weights="/nonexistent/b0.pth"))
    with pytest.raises(ValueError, match="model.size='huge'"):
        load_model_config("nomad_pointgoal", "huge")
    with pytest.raises(ValueError, match="len_traj_pred=6"):
        build_model(load_model_config("nomad_pointgoal", "small", len_traj_pred=6))


def test_ema_keeps_the_parameters_and_gives_the_state_dict_formula(root):
    """EMA.update finds the model's parameters once and reads its buffers each update: the shadows equal the
    state_dict formula (lerp of every float tensor, integer buffers copied) after training steps, a parameter's
    data replaced in place of the object (as ``.to()`` does) and a buffer replaced."""
    from rvn_il.train.ema import EMA

    cfg = load_model_config("nomad_pointgoal", "small")
    batch = make_dataset(root, cfg, {"progress": False}).get_batch(range(4))
    torch.manual_seed(0)
    model = build_model(cfg).train()
    ema, ref = EMA(model), {k: v.detach().clone() for k, v in model.state_dict().items()}
    opt = torch.optim.AdamW(model.parameters(), lr=1e-3)
    gen = torch.Generator().manual_seed(0)
    for step in range(4):
        model(batch, gen)["loss"].backward()
        opt.step()
        opt.zero_grad()
        if step == 2:
            weight = next(model.parameters())
            weight.data = weight.data.clone() + 1.0
            model.action_min = model.action_min.clone() - 1.0  # a registered buffer, replaced
        d = ema.decay()
        ema.update(model)
        with torch.no_grad():
            for k, v in model.state_dict().items():
                ref[k] = torch.lerp(ref[k], v, 1.0 - d) if v.is_floating_point() else v.clone()
    for k, v in ref.items():
        torch.testing.assert_close(ema.shadow[k], v, rtol=0, atol=1e-6, msg=k)
    net = torch.nn.Sequential(torch.nn.Linear(3, 4), torch.nn.BatchNorm1d(4))  # an integer buffer: copied
    ema = EMA(net)
    for _ in range(3):
        net(torch.randn(5, 3))
        ema.update(net)
    assert ema.shadow["1.num_batches_tracked"] == 3 and torch.equal(ema.shadow["1.weight"], net[1].weight)


def test_ema_warms_up_like_diffusers_0_11():
    """diffusers 0.11.1's EMAModel.step takes get_decay(optimization_step) before counting the update, and
    get_decay(n) = 1 - n^-power for n >= 2, else 0: its updates take decays 0, 0, 1 - 2^-power, 1 - 3^-power, ..."""
    from rvn_il.train.ema import EMA

    net = torch.nn.Linear(2, 1)
    ema = EMA(net, power=0.75)
    shadows = []
    for value in (1.0, 2.0, 3.0, 4.0):
        with torch.no_grad():
            net.weight.fill_(value)
        ema.update(net)
        shadows.append(float(ema.shadow["weight"][0, 0]))
    d3, d4 = 1 - 2 ** -0.75, 1 - 3 ** -0.75
    assert shadows == pytest.approx([1.0, 2.0, d3 * 2.0 + (1 - d3) * 3.0, d4 * (d3 * 2.0 + (1 - d3) * 3.0) + (1 - d4) * 4.0])
    for _ in range(6):
        ema.update(net)
    assert ema.decay() == pytest.approx(1 - 10 ** -0.75)  # the 11th update's
    before = ema.shadow["weight"].clone()
    with torch.no_grad():
        net.weight.fill_(2.0)
    d = ema.decay()
    ema.update(net)
    torch.testing.assert_close(ema.shadow["weight"], d * before + (1 - d) * 2.0)


@pytest.mark.parametrize("name", ["vint_pointgoal", "nomad_pointgoal"])
def test_channels_last_training_layout_keeps_values_and_checkpoints(name, tmp_path):
    """rvn-train's NHWC encoder (use_channels_last) computes what NCHW computes; its checkpoint
    (save_checkpoint) loads into an NCHW model (a policy) and gives the same tokens."""
    cfg = load_model_config(name, "small")
    torch.manual_seed(0)
    nchw = build_model(cfg).eval()
    nhwc = build_model(cfg).eval()
    nhwc.load_state_dict(nchw.state_dict())
    nhwc.use_channels_last()
    conv = next(p for p in nhwc.obs_encoder.parameters() if p.dim() == 4)
    assert conv.is_contiguous(memory_format=torch.channels_last) and not conv.is_contiguous()
    images = torch.rand(6, 3, 64, 64, generator=torch.Generator().manual_seed(2))
    with torch.inference_mode():
        torch.testing.assert_close(nhwc.encode_frames(images), nchw.encode_frames(images), rtol=1e-4, atol=1e-5)
        ckpt = save_checkpoint(tmp_path / "model", 1, nhwc.state_dict(), {"model": name}, {"step": 1})
        back = build_model(cfg).eval()
        load_state_dict_checked(back, read_weights(ckpt, name), ckpt)
        torch.testing.assert_close(back.encode_frames(images), nchw.encode_frames(images), rtol=1e-4, atol=1e-5)


@pytest.mark.parametrize("name, size", [("vint_pointgoal", "small"), ("nomad_pointgoal", "small"), ("nomad_pointgoal", "full")])
def test_packed_encoder_gives_the_tokens_of_the_forward(name, size):
    """The encoder's inference form (a policy's encode_frames(fast=True)) gives the module forward's tokens to
    float rounding, for GroupNorm (NoMaD) and BatchNorm with running statistics (ViNT), one frame or several,
    uint8 or float, NCHW or NHWC weights; its packed weights follow an in-place change; autograd and training
    mode take the module forward."""
    cfg = load_model_config(name, size)
    torch.manual_seed(0)
    model = build_model(cfg).eval()
    g = torch.Generator().manual_seed(5)
    with torch.no_grad():  # norms away from their initial identity, so that a mistaken affine or statistic shows
        for m in model.obs_encoder.modules():
            if isinstance(m, (torch.nn.GroupNorm, torch.nn.BatchNorm2d)):
                m.weight.uniform_(0.5, 1.5, generator=g)
                m.bias.uniform_(-0.3, 0.3, generator=g)
            if isinstance(m, torch.nn.BatchNorm2d):
                m.running_mean.uniform_(-0.2, 0.2, generator=g)
                m.running_var.uniform_(0.5, 2.0, generator=g)
    w, h = model.image_size
    frames = torch.randint(0, 256, (3, 3, h, w), dtype=torch.uint8, generator=g)
    with torch.inference_mode():
        want = model.encode_frames(frames)
        assert model.encode_frames(frames, fast=True).shape == want.shape
        torch.testing.assert_close(model.encode_frames(frames, fast=True), want, rtol=0, atol=2e-5)
        torch.testing.assert_close(model.encode_frames(frames[1:2].float() / 255, fast=True), want[1:2], rtol=0, atol=2e-5)
        model.fast_encoding = False  # the reference path: the forward itself
        assert torch.equal(model.encode_frames(frames, fast=True), want)
        model.fast_encoding = True
        packed = model.obs_encoder.packed_weights()
        assert model.obs_encoder.packed_weights() is packed
    with torch.no_grad():
        model.use_channels_last()
        torch.testing.assert_close(model.encode_frames(frames, fast=True), want, rtol=0, atol=2e-5)
        model.obs_encoder.compress.bias.add_(1.0)
        torch.testing.assert_close(model.encode_frames(frames, fast=True), want + 1.0, rtol=0, atol=2e-5)
    model.train()
    torch.manual_seed(1)
    trained = model.encode_frames(frames, fast=True)  # training: the module forward, with autograd
    assert trained.requires_grad


def test_encoder_width_whose_channels_16_does_not_divide(root):
    """width_coefficient 0.5 gives EfficientNet stages of 56 channels (56 // 16 = 3 groups would not divide
    them): the GroupNorm swap takes whole groups (2 of 28), and the model trains one step and predicts."""
    cfg = load_model_config("nomad_pointgoal", "small", width_coefficient=0.5, encoding_size=128)
    model = build_model(cfg)
    norms = [m for m in model.obs_encoder.modules() if isinstance(m, torch.nn.GroupNorm)]
    assert norms and all(m.num_channels % m.num_groups == 0 for m in norms)
    assert any(m.num_channels == 56 and m.num_groups == 2 for m in norms)
    batch = make_dataset(root, cfg, {"progress": False}).get_batch(range(4))
    out = model(batch, torch.Generator().manual_seed(0))
    out["loss"].backward()
    assert torch.isfinite(out["loss"])


@pytest.mark.parametrize("name", ["vint_pointgoal", "nomad_pointgoal"])
def test_train_compile_traces_every_part_it_compiles(root, name, monkeypatch, tmp_path):
    """train.compile (compile_for_training) compiles the encoder, the Transformer and the decoder: a training step
    traces one graph for each. torch.compile does not trace a module whose forward is in torch.nn's own files, so a
    plain nn.TransformerEncoder or nn.Sequential ran eagerly. Traced here with dynamo's ``eager`` backend: the same
    capture as rvn-train's, without inductor's minutes of kernel compiling."""
    from torch._dynamo.utils import counters
    from torch._inductor import config

    from rvn_il.models.compiled import compile_for_training

    compile_module = torch.nn.Module.compile
    modes = []
    monkeypatch.setattr(torch.nn.Module, "compile",
                        lambda self, **kw: (modes.append(kw), compile_module(self, backend="eager"))[1])
    monkeypatch.setenv("TORCHINDUCTOR_CACHE_DIR", str(tmp_path / "kernels"))
    cfg = load_model_config(name, "small")
    batch = make_dataset(root, cfg, {"progress": False}).get_batch(range(4))
    torch.manual_seed(0)
    parts = {"obs_encoder", "transformer", "noise_pred_net" if name == "nomad_pointgoal" else "decoder"}
    torch._dynamo.reset()
    counters.clear()
    with config.patch(fallback_random=config.fallback_random):  # compile_for_training sets it
        model = compile_for_training(build_model(cfg).train())
        model(batch, torch.Generator().manual_seed(0))["loss"].backward()
    assert counters["stats"]["unique_graphs"] == len(parts), dict(counters["stats"])
    assert not counters["graph_break"], dict(counters["graph_break"])
    assert modes == [{"mode": None}] * len(parts)  # torch.compile's default mode


def test_train_compile_mode_auto_graphs_one_gpu_only():
    """rvn-train's train.compile_mode=auto (the default): CUDA graphs (reduce-overhead) on one CUDA device, where their
    CUDA test passed; torch.compile's default on a CPU and with several ranks; a mode given is kept."""
    from rvn_il.train.choices import training_compile_mode

    assert training_compile_mode("auto", "cuda", 1) == "reduce-overhead"
    assert training_compile_mode("auto", "cuda", 4) == training_compile_mode("auto", "cpu", 1) == "default"
    assert training_compile_mode("default", "cuda", 1) == "default"
    assert training_compile_mode("reduce-overhead", "cuda", 4) == "reduce-overhead"


def test_train_compile_mode_reaches_every_part(root, monkeypatch, tmp_path):
    """rvn-train's ``train.compile_mode`` (reduce-overhead: CUDA graphs for host-bound steps on a GPU) is torch.compile's
    mode for every part compile_for_training compiles; an unknown mode is refused before any work, naming the setting
    and the choices. Here compiling is recorded, not done: the parts run eagerly (tests/test_compiled.py compiles)."""
    from torch._inductor import config

    from rvn_il.models.compiled import compile_for_training
    from rvn_il.train.cli import train

    seen = []
    monkeypatch.setattr(torch.nn.Module, "compile", lambda self, **kw: seen.append((type(self).__name__, kw)))
    common = ["model=vint_pointgoal", "model.size=small", f"data.root={root}", "train.max_steps=1", "train.batch_size=4",
              "data.num_workers=0", "device=cpu", f"cache_dir={tmp_path / 'cache'}", "train.compile=true"]
    with config.patch(fallback_random=config.fallback_random):
        train([*common, f"out_dir={tmp_path / 'ro'}", "train.compile_mode=reduce-overhead"])
        assert [kw for _, kw in seen] == [{"mode": "reduce-overhead"}] * 3, seen
        assert (tmp_path / "ro" / "model" / "ckpt_00000001").is_dir()
        seen.clear()
        train([*common, f"out_dir={tmp_path / 'auto'}"])  # the default, auto: on a CPU torch.compile's default
        assert [kw for _, kw in seen] == [{"mode": None}] * 3, seen
        seen.clear()
        with pytest.raises(ValueError, match="train.compile_mode='max-autotune'; choose one of auto, default, "
                                             "reduce-overhead"):
            train([*common, f"out_dir={tmp_path / 'bad'}", "train.compile_mode=max-autotune"])
        assert not (tmp_path / "bad" / "model").exists()
        with pytest.raises(ValueError, match="compile mode 'max-autotune': choose one of default, reduce-overhead"):
            compile_for_training(build_model(load_model_config("vint_pointgoal", "small")), mode="max-autotune")
    assert seen == []


def test_train_compile_gives_each_torchrun_rank_its_share_of_the_compile_pool(monkeypatch):
    """Under torchrun (LOCAL_WORLD_SIZE ranks on a node) inductor's pool of compile processes is cores // ranks (at
    least 2) in each rank, not one per core in every rank; TORCHINDUCTOR_COMPILE_THREADS, when the user set it, wins."""
    from torch._inductor import config

    from rvn_data.worker_threads import compile_threads, threads_per_worker
    from rvn_il.models.compiled import compile_for_training

    monkeypatch.setattr(torch.nn.Module, "compile", lambda self, **kw: None)
    monkeypatch.delenv("TORCHINDUCTOR_COMPILE_THREADS", raising=False)
    with config.patch(fallback_random=config.fallback_random, compile_threads=999):
        monkeypatch.setenv("LOCAL_WORLD_SIZE", "2")
        compile_for_training(build_model(load_model_config("vint_pointgoal", "small")))
        assert config.compile_threads == max(2, threads_per_worker(2)) == compile_threads(threads_per_worker(2))
        config.compile_threads = 999
        monkeypatch.setenv("TORCHINDUCTOR_COMPILE_THREADS", "3")  # the user's: inductor read it when it loaded
        compile_for_training(build_model(load_model_config("vint_pointgoal", "small")))
        assert config.compile_threads == 999
        monkeypatch.delenv("TORCHINDUCTOR_COMPILE_THREADS")
        monkeypatch.setenv("LOCAL_WORLD_SIZE", "1")  # one process: inductor's own choice
        compile_for_training(build_model(load_model_config("vint_pointgoal", "small")))
        assert config.compile_threads == 999


@pytest.mark.parametrize("name", ["nomad_pointgoal", "vint_pointgoal"])
def test_imagenet_weights_reach_the_encoder_group_norm_or_not(name, tmp_path):
    """model.imagenet_weights: NoMaD's encoder (BatchNorm replaced by GroupNorm) keeps the file's normalisation scale
    and shift, as ViNT's (BatchNorm) does; the weights were loaded before the replacement, which then reset them."""
    from efficientnet_pytorch import EfficientNet
    from safetensors.torch import save_file

    cfg = load_model_config(name, "small")
    size = cfg["image_size"]
    net = EfficientNet.from_name("efficientnet-b0", image_size=[size[1], size[0]], width_coefficient=cfg["width_coefficient"],
                                 depth_coefficient=cfg["depth_coefficient"])
    state = {k: v.clone() for k, v in net.state_dict().items()}
    state["_bn0.weight"].fill_(3.0)
    state["_bn0.bias"].fill_(0.25)
    save_file(state, str(tmp_path / "b0.safetensors"))
    model = build_model(load_model_config(name, "small", imagenet_weights=str(tmp_path / "b0.safetensors")))
    encoders = [m for m in model.modules() if type(m).__name__ == "ObsEncoder"]
    assert encoders and all(e.net._bn0.weight.detach().eq(3.0).all() and e.net._bn0.bias.detach().eq(0.25).all() for e in encoders)
    assert any(type(e.net._bn0).__name__ == "GroupNorm" for e in encoders) == (name == "nomad_pointgoal")


@pytest.mark.parametrize("warmup_steps, first", [(0, 1.0), (None, 0.25), (2, 0.5)])
def test_warmup_steps_zero_turns_the_warm_up_off(warmup_steps, first):
    """train.warmup_steps=0 starts at the full learning rate (it took warmup_frac's 4 % instead: 4 of 100 steps);
    null takes warmup_frac."""
    from dataclasses import asdict

    from rvn_il.train.optimisation import optimisation
    from rvn_il.train.settings import TrainLoopConfig

    tcfg = {**asdict(TrainLoopConfig()), "max_steps": 100, "batch_size": 4, "lr": 1e-3, "warmup_steps": warmup_steps}
    run = optimisation(load_model_config("vint_pointgoal", "small"), tcfg, range(400), 1, torch.device("cpu"))
    assert run.sched.get_last_lr()[0] == pytest.approx(1e-3 * first)
