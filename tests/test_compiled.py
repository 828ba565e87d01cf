"""train.compile and policy.compile (issue 32, rvn_il/models/compiled.py): through rvn-train's CLI and
load_policy, the compiled paths give the plain paths' losses, checkpoints and actions."""
from __future__ import annotations

import glob
import os
import subprocess
import sys

import numpy as np
import pytest
import torch
from conftest import QUICK_COMPILE_ENV
from safetensors.torch import load_file

from rvn_il.data.synthetic import render_frame, write_synthetic_gnm
from rvn_il.models import build_model, load_model_config
from rvn_il.models.compiled import compile_for_inference
from rvn_il.models.graph_calls import STRUCTURES, KeyedCall, as_buffers, register_structure
from rvn_il.models.sampling_plan import draw_noise
from rvn_il.policies import load_policy
from rvn_il.policies.policy import intra_op_threads

pytestmark = pytest.mark.slow  # torch.compile builds its kernels: about two minutes on one core

ENV = {**os.environ, "OMP_NUM_THREADS": "1"}


def losses(out_dir) -> dict[str, list[float]]:
    from tensorboard.backend.event_processing.event_accumulator import EventAccumulator

    acc = EventAccumulator(glob.glob(f"{out_dir}/tb/model")[0])
    acc.Reload()
    return {tag: [e.value for e in acc.Scalars(tag)] for tag in acc.Tags()["scalars"] if tag.endswith("loss")}


# every kind of part, fewer of some (inductor's compile time grows with the graphs): one Transformer layer, a 2-level
# U-Net, small's encoder with one repeated MBConv block (depth 0.3: 8 blocks instead of 10), which draws drop-connect
FEWER_LAYERS = ["model.num_layers=1", "model.sizes.small.down_dims=[32,64]", "model.sizes.small.depth_coefficient=0.3"]
# Every compile here makes scalar C++ kernels: what this file checks is RVN's wiring (in-place compile, parameter
# names, random draws, graphs shared by structure, the kernel cache's place), not inductor's vector code, and
# vectorised kernels took about twice as long to compile on the 2-core machine: the training run 164 s of its 187
# (101 s in all with scalar ones); the policy's encoder and sampling graph 102-125 s against 57. The training runs
# get them through the environment, the compiles in this process through inductor's config (`scalar_kernels`).
# The training runs also get inductor's C++ wrapper (TORCHINDUCTOR_CPP_WRAPPER=1), as policy.compile on a CPU has it
# by default (rvn_il.models.graph_calls.cpp_wrapper): a graph's kernels and its wrapper in one translation unit, one
# compiler call per graph instead of one per kernel, each of which loads inductor's 140 MB precompiled header (~0.75 s
# a kernel): the compiled run 111 s instead of 156 on the 2-core machine beside another test, tests/test_rl.py's
# compiled run 65 instead of 99. And every compile here is unoptimised (TORCHINDUCTOR_DEBUG_COMPILE=1: g++ -O0 -g
# instead of -O3; the kernels run a few times): the training run's losses equal -O3's to the last bit, the tests'
# tolerances are unchanged; on the 2-core machine g++'s share of the training run 56 -> 18 s (113 -> 68 s in all),
# this file alone 187 -> 133 s.
# tests/conftest.py's QUICK_COMPILE_ENV is the training runs' environment.


@pytest.fixture(autouse=True)
def scalar_kernels(monkeypatch):
    """Inductor's C++ kernels without vector instructions for the compiles in this process (cpp.simdlen 1: no vector
    ISA of that width, so none is picked), compiled unoptimised (inductor reads the variable at each compile)."""
    import torch._inductor.config as inductor

    monkeypatch.setenv("TORCHINDUCTOR_DEBUG_COMPILE", QUICK_COMPILE_ENV["TORCHINDUCTOR_DEBUG_COMPILE"])
    with inductor.patch({"cpp.simdlen": 1}):
        yield


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    """NoMaD-PointGoal (small, 3 training steps, 2 denoising steps: the compiled sampling graph unrolls them, so each
    step adds to its compile time; two are a step that draws noise and the last, which does not) trained by rvn-train
    plainly and with train.compile=true."""
    base = tmp_path_factory.mktemp("compiled")
    write_synthetic_gnm(base / "expert", 3, 24, image_size=64, seed=0)
    common = ["model=nomad_pointgoal", f"data.root={base / 'expert'}", "model.size=small", "train.max_steps=3",
              "train.batch_size=4", "train.log_every=1", "model.num_diffusion_iters=2", "data.num_workers=0",
              f"cache_dir={base / 'cache'}", *FEWER_LAYERS]
    for name, extra, env in (("plain", [], ENV), ("compiled", ["train.compile=true"], {**ENV, **QUICK_COMPILE_ENV})):
        r = subprocess.run([sys.executable, "-m", "rvn_il.train.cli", f"out_dir={base / name}", *common, *extra],
                           capture_output=True, text=True, env=env, timeout=900)
        assert r.returncode == 0, r.stderr[-3000:]
    return base


def test_compiled_training_gives_the_plain_losses_and_checkpoint(runs):
    """The losses check the training: with the parts compiled as copies whose updates never reach the forward
    (measured 2026-12-03: the optimizer steps the model, the compiled copies keep its first weights), train/loss was
    2.7 % and 11.5 % off at steps 2 and 3, against a 1e-4 tolerance. Three AdamW steps at lr 1e-4 move a weight by
    less than the checkpoints' atol, so that comparison checks names, shapes and gross corruption only."""
    plain, compiled = losses(runs / "plain"), losses(runs / "compiled")
    assert set(plain) == set(compiled) and "train/diffusion_loss" in plain
    for tag, values in plain.items():  # same draws (dropout, drop-connect, noise): float rounding apart
        np.testing.assert_allclose(compiled[tag], values, rtol=1e-4, atol=1e-6, err_msg=tag)
    a = load_file(str(runs / "plain" / "model" / "ckpt_00000003" / "weights.safetensors"))
    b = load_file(str(runs / "compiled" / "model" / "ckpt_00000003" / "weights.safetensors"))
    assert a.keys() == b.keys()  # compiled in place: the plain model's names, loadable by every tool
    for k in a:
        torch.testing.assert_close(b[k], a[k], rtol=0, atol=2e-3, msg=k)
    assert list((runs / "cache" / "compiled").iterdir()), "compiled kernels belong under the cache root"


def test_compiled_policy_acts_as_the_plain_one(runs, tmp_path, monkeypatch):
    monkeypatch.setenv("TORCHINDUCTOR_CACHE_DIR", str(tmp_path / "kernels"))
    plain = load_policy(runs / "plain")
    compiled = load_policy(runs / "plain", compile=True)
    assert compiled.members[0].model.sampling_graph is not None and plain.members[0].model.sampling_graph is None
    for p in (plain, compiled):
        p.reset()
    for t in range(12):
        obs = {"rgb": render_frame(np.array([0.2 * t, 0.05 * t]), 0.1 * t, 64),
               "pointgoal": np.array([3.0 - 0.2 * t, 1.0 - 0.1 * t], np.float32)}
        assert compiled.act(obs) == plain.act(obs), f"decision {t}"
        np.testing.assert_allclose(compiled.last_waypoints, plain.last_waypoints, atol=1e-4)
    assert list((tmp_path / "kernels").iterdir())
    with pytest.raises(ValueError, match=r"policy.compile='yes': give true or false"):
        load_policy(runs / "plain", compile="yes")


def tiny_nomad(seed: int, down_dims: list[int]) -> torch.nn.Module:
    """A NoMaD-PointGoal network like the runs' (FEWER_LAYERS, 2 denoising steps), with its own weights."""
    cfg = load_model_config("nomad_pointgoal", "small")
    cfg.update(num_layers=1, down_dims=down_dims, depth_coefficient=0.3, num_diffusion_iters=2)
    torch.manual_seed(seed)
    return build_model(cfg).eval()


def test_compiled_networks_of_other_structures_share_no_graph(tmp_path, monkeypatch):
    """policy.compile on a CPU compiles the encoder and one denoising step as graphs that check only their inputs'
    guards and a structure number (rvn_il.models.compiled.KeyedCall): networks of the same structure share them, each
    with its own weights, and one of another U-Net gets graphs of its own. Each gives its own network's plain outputs.
    On one thread, as a policy decides: after the policy test the first two networks reuse its graphs (same structure;
    dynamo guards the thread count, so on the process's two threads they compiled every graph again)."""
    from torch._dynamo.utils import counters

    monkeypatch.setenv("TORCHINDUCTOR_CACHE_DIR", str(tmp_path / "kernels"))
    nets = [tiny_nomad(0, [32, 64]), tiny_nomad(1, [32, 64]), tiny_nomad(0, [16, 32])]
    g = torch.Generator().manual_seed(0)
    frames = torch.rand(4, 1, 3, 64, 64, generator=g)  # one at a time, as a policy encodes them
    x, noise = draw_noise(nets[0]._plan(), (8, 8, 2), g, torch.device("cpu"))
    goal = torch.tensor([[3.0, 1.0]])
    results, graphs = [], []
    with torch.inference_mode(), intra_op_threads(1):
        for net in nets:
            compile_for_inference(net, "cpu")
            graphs.append(counters["stats"]["unique_graphs"])
            tokens = torch.cat([net.frame_encoder(frame) for frame in frames])
            torch.testing.assert_close(tokens, net.obs_encoder.forward_packed(frames[:, 0]), rtol=0, atol=1e-4)
            tokens = tokens.unsqueeze(0)
            results.append(net.sampling_graph(tokens, goal, None, x, noise))
            torch.testing.assert_close(results[-1], net.sample_packed(tokens, goal, None, x, noise), rtol=0, atol=1e-4)
    a, b, c = (net.sampling_graph.structure for net in nets)
    assert a == b != c and len({net.frame_encoder.structure for net in nets}) == 1
    assert not torch.allclose(results[0], results[1])  # the same graphs, each network's own weights
    assert graphs[1] == graphs[2] < counters["stats"]["unique_graphs"]  # the second compiled nothing, the third did


def test_keyed_call_checks_its_inputs_and_structure_not_its_weights(tmp_path, monkeypatch):
    """KeyedCall on a small function: the same structure with other weights reuses the graph and reads those weights
    (also after an in-place change); another structure or another input shape compiles anew."""
    from torch._dynamo.utils import counters

    monkeypatch.setenv("TORCHINDUCTOR_CACHE_DIR", str(tmp_path / "kernels"))

    def scaled(structure, weights, x):
        _, scale = STRUCTURES[structure]
        return torch.relu(x @ weights.packed_0) * scale

    def holder(seed: int, n: int = 4):
        return as_buffers({"w": torch.randn(n, n, generator=torch.Generator().manual_seed(seed))})

    call = KeyedCall(scaled, torch.device("cpu"))
    (wa, la), (wb, lb), (wc, lc) = holder(0), holder(1), holder(2, 3)
    sa, sb = register_structure((2.0,), wa, la), register_structure((2.0,), wb, lb)
    s3, sc = register_structure((3.0,), wa, la), register_structure((2.0,), wc, lc)
    assert sa == sb and len({sa, s3, sc}) == 3
    x = torch.rand(2, 4)
    graphs = counters["stats"]["unique_graphs"]

    def check(structure, weights, x, scale, compiled: int):
        torch.testing.assert_close(call(structure, weights, x), torch.relu(x @ weights.packed_0) * scale)
        assert counters["stats"]["unique_graphs"] - graphs == compiled

    check(sa, wa, x, 2.0, 1)
    check(sb, wb, x, 2.0, 1)  # the same structure: the same graph, wb's weights
    wb.packed_0.mul_(-1)
    check(sb, wb, x, 2.0, 1)
    check(s3, wa, x, 3.0, 2)  # the scale is part of the structure
    check(sa, wa, torch.rand(5, 4), 2.0, 3)  # the input's shape is guarded
    check(sc, wc, torch.rand(2, 3), 2.0, 4)


def test_keyed_call_without_guard_filters_checks_every_guard(tmp_path, monkeypatch):
    """On a torch before guard_filter_fn (2.8) a KeyedCall compiles with every guard: the same results, and a change
    that only the dropped guards would see (the structure's entry, a global) compiles anew."""
    import rvn_il.models.graph_calls as graph_calls

    monkeypatch.setenv("TORCHINDUCTOR_CACHE_DIR", str(tmp_path / "kernels"))
    monkeypatch.setattr(graph_calls, "GUARD_FILTER", False)
    weights, layout = as_buffers({"w": torch.randn(4, 4, generator=torch.Generator().manual_seed(0))})
    structure = register_structure((0.5,), weights, layout)

    def halved(structure, weights, x):
        return torch.relu(x @ weights.packed_0) * STRUCTURES[structure][1]

    call = KeyedCall(halved, torch.device("cpu"))
    x = torch.rand(3, 4)
    torch.testing.assert_close(call(structure, weights, x), torch.relu(x @ weights.packed_0) * 0.5)
    STRUCTURES[structure] = (layout, 0.25)  # what the filter leaves unchecked (a global) is checked: compiled anew
    try:
        torch.testing.assert_close(call(structure, weights, x), torch.relu(x @ weights.packed_0) * 0.25)
    finally:
        STRUCTURES[structure] = (layout, 0.5)

@pytest.mark.skipif(not torch.cuda.is_available(), reason="CUDA graphs need a GPU (run on a GPU node: issue 32)")
def test_reduce_overhead_training_on_cuda_gives_the_plain_losses_and_checkpoint(tmp_path):
    """train.compile_mode=reduce-overhead on a GPU: each compiled part's forward and backward replays as a CUDA
    graph, and rvn-train marks each step's start; the losses and weights are the plain fp32 step's (float rounding
    apart), the EMA's included. Both runs in fp32 proper (NVIDIA_TF32_OVERRIDE=0): cuDNN convolves in TF32 by default
    on Ampere and later, whose 10-bit products could put two convolution algorithms ~1e-3 apart, the tolerance
    itself."""
    write_synthetic_gnm(tmp_path / "expert", 3, 24, image_size=64, seed=0)
    common = ["model=nomad_pointgoal", f"data.root={tmp_path / 'expert'}", "model.size=small", "train.max_steps=4",
              "train.batch_size=4", "train.log_every=1", "model.num_diffusion_iters=4", "data.num_workers=0",
              "device=cuda", f"cache_dir={tmp_path / 'cache'}", *FEWER_LAYERS]
    for name, extra in (("plain", []), ("graphs", ["train.compile=true", "train.compile_mode=reduce-overhead"])):
        r = subprocess.run([sys.executable, "-m", "rvn_il.train.cli", f"out_dir={tmp_path / name}", *common, *extra],
                           capture_output=True, text=True, env={**ENV, "NVIDIA_TF32_OVERRIDE": "0"}, timeout=900)
        assert r.returncode == 0, r.stderr[-3000:]
    plain, graphs = losses(tmp_path / "plain"), losses(tmp_path / "graphs")
    assert set(plain) == set(graphs) and "train/diffusion_loss" in plain
    for tag, values in plain.items():
        np.testing.assert_allclose(graphs[tag], values, rtol=1e-3, atol=1e-5, err_msg=tag)
    a = load_file(str(tmp_path / "plain" / "model" / "ckpt_00000004" / "weights.safetensors"))
    b = load_file(str(tmp_path / "graphs" / "model" / "ckpt_00000004" / "weights.safetensors"))
    assert a.keys() == b.keys()
    for k in a:
        torch.testing.assert_close(b[k], a[k], rtol=0, atol=2e-3, msg=k)


def test_cpu_graphs_compile_with_the_cpp_wrapper_unless_turned_off(monkeypatch):
    """policy.compile's CPU graphs use inductor's C++ wrapper (one compiler call per graph); TORCHINDUCTOR_CPP_WRAPPER=0
    turns it off, as the user would expect of inductor's own variable."""
    from rvn_il.models.graph_calls import CompiledCall, cpp_wrapper

    monkeypatch.delenv("TORCHINDUCTOR_CPP_WRAPPER", raising=False)
    assert cpp_wrapper()
    seen = []
    monkeypatch.setattr(torch, "compile", lambda fn, **kw: seen.append(kw["options"]["cpp_wrapper"]) or fn)
    CompiledCall(torch.relu, "cpu")
    monkeypatch.setenv("TORCHINDUCTOR_CPP_WRAPPER", "0")
    CompiledCall(torch.relu, "cpu")
    assert seen == [True, False]
