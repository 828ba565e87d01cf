"""train.graph_act (`rvn_rl.graphed.GraphedAct`): the rollouts' act replayed from static buffers (a CUDA graph on a
GPU) gives the plain act's actions, log-probs, values and states, across episode starts and weights updated in place;
through rvn-rl on a CPU (no graph: the static path run eagerly, a warning) the run is the plain run's to the byte."""
from __future__ import annotations

import json
import logging
import re

import pytest
import torch

from rvn_rl.graphed import GraphedAct
from rvn_rl.model import PointNavResNetPolicy

CUDA = pytest.mark.skipif(not torch.cuda.is_available(), reason="needs a GPU: CUDA graphs")


def acts(actor, policy, device: str, steps: int = 6, n: int = 3, seed: int = 0) -> list[tuple]:
    """``steps`` acts of ``actor`` on n envs' random frames (an env starting an episode at steps 2 and 4), each
    drawing from a generator of ``seed``; before step 3 ``policy``'s weights change in place. Returns each act's
    (action, log-prob, values, state) on the CPU."""
    data = torch.Generator().manual_seed(seed)
    draw = torch.Generator(device=device).manual_seed(seed + 1)
    state = policy.initial_state(n, device)
    prev, out = torch.zeros(n, dtype=torch.long, device=device), []
    for t in range(steps):
        obs = {"rgb": torch.randint(0, 256, (n, 64, 64, 3), generator=data, dtype=torch.uint8).to(device),
               "pointgoal": torch.randn(n, 2, generator=data).to(device)}
        masks = torch.ones(n, device=device)
        if t in (2, 4):
            masks[t % n] = 0
        if t == 3:  # new weights between two acts, in place as the optimiser writes them (the same on any device)
            with torch.no_grad():
                for p in policy.parameters():
                    p.add_(0.05 * torch.randn(p.shape, generator=data).to(device))
        with torch.no_grad():
            action, logp, values, state = actor.act(obs, state, prev, masks, generator=draw)
        prev = action
        out.append(tuple(x.cpu() for x in (action, logp, values, state)))
    return out


def policies(device: str) -> tuple[PointNavResNetPolicy, PointNavResNetPolicy]:
    torch.manual_seed(0)
    a = PointNavResNetPolicy(64, "resnet18", base_planes=16, ngroups=8, input_size=64, hidden_size=32).to(device)
    b = PointNavResNetPolicy(64, "resnet18", base_planes=16, ngroups=8, input_size=64, hidden_size=32).to(device)
    b.load_state_dict(a.state_dict())
    return a.eval(), b.eval()


def test_static_act_gives_the_plain_acts_across_resets_and_updates():
    """On a CPU (no graph): the same bytes as the plain act, an update's in-place weights included; one record."""
    plain, same = policies("cpu")
    graphed = GraphedAct(same, cuda_graph=False)
    want, got = acts(plain, plain, "cpu"), acts(graphed, same, "cpu")
    assert graphed.recorded == 1
    for a, b in zip(want, got, strict=True):
        assert all(torch.equal(x, y) for x, y in zip(a, b)), (a, b)
    assert len({tuple(a[0].tolist()) for a in want}) > 1  # the actions vary: the comparison says something


def test_each_batch_shape_records_once_and_alternating_shapes_replay_their_own():
    """train.double_buffered acts for two halves of the envs in turn (16 and 14 envs in scale=small): one recording
    each, then each half's acts are the plain act's on that half."""
    plain, same = policies("cpu")
    graphed = GraphedAct(same, cuda_graph=False)
    halves = [[], []]
    for t in range(4):
        for h, n in enumerate((3, 2)):
            halves[h].append(acts(graphed, same, "cpu", steps=1, n=n, seed=10 * t + h)[0])
    assert graphed.recorded == 2
    for h, n in enumerate((3, 2)):
        want = [acts(plain, plain, "cpu", steps=1, n=n, seed=10 * t + h)[0] for t in range(4)]
        for a, b in zip(want, halves[h], strict=True):
            assert all(torch.equal(x, y) for x, y in zip(a, b)), (a, b)


@CUDA
def test_cuda_graph_act_gives_the_plain_acts():
    """On a GPU: one recording, then replays whose actions are the plain act's (the same kernels on the same inputs;
    values and states to float rounding), across episode starts and an update's in-place weights."""
    plain, same = policies("cuda")
    graphed = GraphedAct(same, cuda_graph=True)
    want, got = acts(plain, plain, "cuda"), acts(graphed, same, "cuda")
    assert graphed.recorded == 1 and len(graphed.graphs) == 1
    for (a, la, va, sa), (b, lb, vb, sb) in zip(want, got, strict=True):
        assert torch.equal(a, b)
        torch.testing.assert_close(lb, la)
        torch.testing.assert_close(vb, va)
        torch.testing.assert_close(sb, sa)


def run(tmp_path, name: str, *overrides: str) -> tuple[list[dict], bytes]:
    from rvn_rl.cli import compose
    from rvn_rl.trainer import train

    from test_rl_overlap import TINY

    out = tmp_path / name
    train(compose(["algo=ppo", f"out_dir={out}", *TINY, *overrides]))
    rows = [json.loads(line) for line in (out / "metrics.jsonl").read_text().splitlines()]
    latest = out / "checkpoints" / (out / "checkpoints" / "latest").read_text().strip()
    return rows, (latest / "weights.safetensors").read_bytes()


KEYS = ("env_steps", "episodes", "value_loss", "action_loss", "entropy", "grad_norm", "reward")


@pytest.mark.slow
@pytest.mark.parametrize("overlap", [False, True])
def test_rvn_rl_with_graph_act_on_a_cpu_is_the_plain_run(tmp_path, caplog, overlap):
    """rvn-rl train.graph_act=true on a CPU: a warning, and the run (acts through `GraphedAct`'s static buffers,
    with train.overlap's actor too) writes the plain run's losses and weights to the byte."""
    extra = ["device=cpu", f"train.overlap={str(overlap).lower()}"]
    with caplog.at_level(logging.WARNING, logger="rvn_rl.trainer"):
        rows, weights = run(tmp_path, "graphed", "train.graph_act=true", *extra)
    assert any("train.graph_act=true records the act as a CUDA graph" in r.message for r in caplog.records)
    plain_rows, plain_weights = run(tmp_path, "plain", *extra)
    assert [[r.get(k) for k in KEYS] for r in rows] == [[r.get(k) for k in KEYS] for r in plain_rows]
    assert weights == plain_weights


@CUDA
@pytest.mark.slow
@pytest.mark.filterwarnings("error:RNN module weights are not part of single contiguous chunk")
@pytest.mark.parametrize("overlap", [False, True])
def test_rvn_rl_with_graph_act_on_cuda_learns_as_the_plain_run(tmp_path, overlap):
    """rvn-rl train.graph_act=true on a GPU (with train.overlap, the actor's copy recorded before the learner thread
    starts): the plain run's episodes and losses to float rounding (cuDNN's last bits vary from run to run there, as
    in tests/test_rl_overlap.py)."""
    extra = ["device=cuda", f"train.overlap={str(overlap).lower()}"]
    rows, _ = run(tmp_path, "graphed", "train.graph_act=true", *extra)
    plain, _ = run(tmp_path, "plain", *extra)
    for a, b in zip(plain, rows, strict=True):
        assert [a.get(k) for k in KEYS[:2]] == [b.get(k) for k in KEYS[:2]]
        for k in KEYS[2:]:
            if b.get(k) is None:
                assert a.get(k) is None, k
            else:
                assert a.get(k) == pytest.approx(b[k], rel=1e-2, abs=1e-4 if k == "action_loss" else 1e-6), k


def test_act_benchmark_prints_the_plain_act_and_names_the_graphed_one_skipped_on_a_cpu():
    """benchmarks/rl_act.py (issue 32's figure for train.graph_act, and with --workers train.double_buffered's two
    acts a step) on a CPU at a tiny size."""
    import subprocess
    import sys
    from pathlib import Path

    script = Path(__file__).resolve().parents[1] / "benchmarks" / "rl_act.py"
    proc = subprocess.run([sys.executable, str(script), "--envs", "3", "--size", "64", "--acts", "2", "--repeats", "1",
                           "--threads", "1", "--workers", "2"], capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    assert "One batched act (CPU; 3 envs, 64²" in proc.stdout
    assert re.search(r"plain +[\d.]+ ms +acting alone allows +\d+ env steps/s +x1\.00", proc.stdout), proc.stdout
    # train.double_buffered's two acts a step, the halves of 2 workers' envs
    assert re.search(r"two halves' acts \(2 \+ 1\) +[\d.]+ ms +acting alone allows +\d+ env steps/s +x[\d.]+",
                     proc.stdout), proc.stdout
    assert "graphed (train.graph_act)      skipped: CUDA graphs need a GPU" in proc.stdout
    bad = subprocess.run([sys.executable, str(script), "--envs", "0"], capture_output=True, text=True, timeout=300)
    assert bad.returncode == 2 and "--envs=0 must be >= 1" in bad.stderr
    bad = subprocess.run([sys.executable, str(script), "--envs", "3", "--workers", "4"], capture_output=True, text=True,
                         timeout=300)
    assert bad.returncode == 2 and "--workers=4: two halves need 2 to --envs=3 workers" in bad.stderr
