"""Per-decision latency on CPU (and, for node.py's rows, a GPU) of the point-goal policies (issues 15, 32): one
``act`` of ViNT, NoMaD (8 samples x 10 steps) and NoMaD-Neg (2 x 8), NoMaD's beside its reference sampling path
(``predict(fast=False)``: module forward and diffusers' ``DDPMScheduler.step``) or, compiled, beside the plain fast
path; a NoMaD decision's parts (:func:`decision_parts`); one frame through each encoder's inference form; what
``policy.depth_veto`` adds to a forward decision.
``benchmarks/train.py`` prints these figures after its training ones (``--latency-only``: these alone); node.py's
decision rows and its ``--warm`` jobs call :func:`decision_ms`.

    python benchmarks/decision.py [--threads N] [--policy-threads 1] [--quick] [--sampler ddpm|ddim] [--compile]
"""
from __future__ import annotations

import argparse
import statistics
import time

import numpy as np
import torch

from rvn_data.conventions import AgentConfig
from rvn_il.data.synthetic import render_frame
from rvn_il.models import build_model, load_model_config
from rvn_il.models.compiled import compile_for_inference
from rvn_il.policies import ControlConfig, Member, NoMaDNegPolicy, PointGoalPolicy
from rvn_il.policies.depth_veto import DepthVeto, predicted_depth
from rvn_il.policies.policy import intra_op_threads


def compile_alone() -> None:
    """Forgets what torch.compile saw earlier in this process, so the next model compiles as in a process of its own
    (as rvn-train and rvn-eval compile it). Otherwise parts whose code another model shares (``ObsEncoder.forward``,
    ``ContextTransformer.forward``) recompile with dynamic sizes (dynamo's automatic dynamic shapes): node.py's
    compiled ViNT step after NoMaD's saw 'images' of 24 frames where NoMaD's had 16, and got a dynamic graph that
    neither rvn-train runs nor a kernel cache filled by rvn-train holds."""
    torch._dynamo.reset()


DECISION_BLOCK = 8  # decisions of one policy in a row when decision_ms times two


def decision_ms(name: str, size: str, decisions: int, threads: int | None = 1,
                sampler: str = "ddpm", device: str = "cpu", reference: bool = True,
                seconds: float | None = None, compile: bool = False,
                profiles: dict | None = None, window: list | None = None) -> tuple[float, float | None]:
    """Median ms per ``act`` of the policy on ``device`` and, for NoMaD models with ``reference``, of
    the same policy on the reference sampling path (same weights and frames, the two timed in turns);
    NoMaD samples with ``sampler`` (policy.sampler). With ``compile`` the first policy
    is compiled (policy.compile; its first decisions, which compile, are warm-up) and the second, with
    ``reference``, is the plain fast path, for any model. After the warm-up, ``decisions`` are
    timed, or with ``seconds`` as many as fit in that time (at least ``decisions``).

    One policy: 3 warm-up decisions. Two policies take turns in blocks of :data:`DECISION_BLOCK` decisions
    (the first block of each is warm-up; the first decision of every block is not timed), so each is timed with
    its own weights in the caches, as in a process of its own, while both see the same load over time.
    Alternating every decision slowed both (NoMaD full, one core of a laptop: compiled 37.1 ms, plain 50.8; in
    blocks of 8: 31.7 and 47.1; each alone in its process: 25.8 and 40.5).

    With ``profiles`` (a dict), 5 more decisions of the first policy are profiled into ``profiles["decision"]``
    (`op_profile.op_table`). ``window`` (a list) receives the timed decisions' [start, end] (``time.perf_counter``)."""
    cfg = load_model_config("nomad_pointgoal" if name == "nomad_neg" else name, size)
    ctrl = ControlConfig.from_agent(AgentConfig())
    if compile:
        paths = ((True, True), (True, False)) if reference else ((True, True),)
    else:
        paths = ((True, False), (False, False)) if name != "vint_pointgoal" and reference else ((True, False),)
    if compile:
        compile_alone()
    policies = []
    for fast, compiled in paths:
        torch.manual_seed(0)
        members = [Member(build_model(cfg).eval().to(device), 0.25) for _ in range(2 if name == "nomad_neg" else 1)]
        for m in members:
            if torch.device(device).type == "cuda":  # as rvn_il.policies.loader.load_member
                m.model.use_channels_last()
            m.model.fast_sampling = m.model.fast_encoding = fast
            if name != "vint_pointgoal":
                m.model.sampler = sampler
            if compiled:
                compile_for_inference(m.model, device)
        policies.append(NoMaDNegPolicy(members, ctrl, 8, device=device, threads=threads) if name == "nomad_neg"
                        else PointGoalPolicy(members, ctrl, 1 if name == "vint_pointgoal" else 8, device=device,
                                             threads=threads))
    frames = [render_frame(np.array([0.25 * t, 0.0]), 0.05 * t, 256) for t in range(min(decisions, 40) + 3)]
    times = [[] for _ in policies]
    for policy in policies:
        policy.reset()
    block = DECISION_BLOCK if len(policies) > 1 else 1
    warm = 3 if block == 1 else block  # decisions not timed first (a compiled policy compiles in its first)
    start, k = None, 0
    while len(times[0]) < decisions or (seconds is not None and time.perf_counter() - start < seconds):
        if k >= warm and start is None:
            start = time.perf_counter()
        for policy, ts in zip(policies, times):
            for j in range(block):  # the same frames for each policy
                t = time.perf_counter()
                policy.act({"rgb": frames[(k + j) % len(frames)], "pointgoal": np.array([4.0, 1.0], np.float32)})
                if k >= warm and (j > 0 or block == 1):  # a block's first decision refills the caches: not timed
                    ts.append(time.perf_counter() - t)
        k += block
    ms = [1e3 * statistics.median(ts) for ts in times]
    if window is not None:
        window[:] = [start, time.perf_counter()]
    if profiles is not None:
        from op_profile import op_table

        def act() -> None:
            for f in frames[:5]:
                with torch.profiler.record_function("policy.act"):
                    policies[0].act({"rgb": f, "pointgoal": np.array([4.0, 1.0], np.float32)})
        profiles["decision"] = op_table(act, torch.device(device).type == "cuda")
    return ms[0], ms[1] if len(ms) > 1 else None


def in_turns(*fns, reps: int, warm: int) -> tuple[float, ...]:
    """Median ms of each of ``fns``, called in turns ``reps`` times each after ``warm`` untimed turns, so that all
    see the same load over time."""
    times: tuple[list, ...] = tuple([] for _ in fns)
    for k in range(warm + reps):
        for fn, ts in zip(fns, times):
            t = time.perf_counter()
            fn()
            if k >= warm:
                ts.append(1e3 * (time.perf_counter() - t))
    return tuple(statistics.median(ts) for ts in times)


def encoder_ms(name: str, size: str, reps: int = 60) -> tuple[float, float]:
    """Median ms to encode one frame (the policy's case) with the encoder's inference form (``encode_frames(fast=True)``:
    rvn_il/models/encoder_packed.py) and with its module forward, the two timed in turns."""
    torch.manual_seed(0)
    model = build_model(load_model_config(name, size)).eval()
    w, h = model.image_size
    frame = torch.rand(1, 3, h, w, generator=torch.Generator().manual_seed(0))
    with torch.inference_mode():
        return in_turns(lambda: model.encode_frames(frame, fast=True), lambda: model.encode_frames(frame),
                        reps=reps, warm=5)


def decision_parts(size: str, reps: int = 20) -> dict[str, float]:
    """Where a plain NoMaD-PointGoal decision's time goes on this thread (issue 32: what bounds the CPU figure): median
    ms of its parts as :meth:`NoMaDPointGoal.predict`'s fast path runs them, timed in turns over the same inputs
    (:func:`in_turns`; ``encoder``: one frame; ``condition``: the Transformer's condition and every step's FiLM
    biases; ``denoise``: the 8 samples' denoising steps with their updates), and, from torch.profiler over one
    ``denoise``, the share of its operator time in matrix products (``matmul_share``) and their rate
    (``matmul_gflops``, from the profiler's FLOP counts). A decision is about the three parts' sum plus the frame's
    preprocessing and the action adapter."""
    from torch.profiler import ProfilerActivity, profile

    from rvn_il.models.sampling_plan import draw_noise

    torch.manual_seed(0)
    model = build_model(load_model_config("nomad_pointgoal", size)).eval()
    w, h = model.image_size
    g = torch.Generator().manual_seed(0)
    frame = torch.rand(1, 3, h, w, generator=g)
    tokens = torch.randn(1, model.context_size + 1, model.encoding_size, generator=g)
    goal, samples = torch.tensor([[4.0, 1.0]]), 8
    with torch.inference_mode():
        packed = model.noise_pred_net.packed_weights()
        part_t = model.plan_film_part(packed)
        x, noise = draw_noise(model._plan(), (samples, model.len_traj_pred, 2), g, torch.device("cpu"))
        biases = model.step_biases(tokens, goal, None, samples, packed, part_t)
        parts = {"encoder": lambda: model.encode_frames(frame, fast=True),
                 "condition": lambda: model.step_biases(tokens, goal, None, samples, packed, part_t),
                 "denoise": lambda: model.denoise_packed(x, noise, biases, packed)}
        out = dict(zip(parts, in_turns(*parts.values(), reps=reps, warm=3)))
        with profile(activities=[ProfilerActivity.CPU], with_flops=True) as prof:
            parts["denoise"]()
    events = [e for e in prof.key_averages() if e.self_cpu_time_total > 0]
    total = sum(e.self_cpu_time_total for e in events)
    mm = [e for e in events if e.key in ("aten::addmm", "aten::mm", "aten::bmm")]
    mm_us = sum(e.self_cpu_time_total for e in mm)
    out["matmul_share"] = mm_us / total
    out["matmul_gflops"] = sum(e.flops for e in mm) / (mm_us * 1e3)
    out["steps"] = len(model._plan())
    return out


def veto_check_ms(size: str, veto: DepthVeto, reps: int = 200) -> float:
    """Median ms that ``policy.depth_veto`` adds to a MOVE_FORWARD decision of NoMaD-PointGoal: the depth
    head on the current frame's token (already encoded by the policy) and the rule on its grid."""
    torch.manual_seed(0)
    model = build_model(load_model_config("nomad_pointgoal", size, depth_aux_weight=0.5)).eval()
    token = torch.randn(model.encoding_size)
    times = []
    with torch.inference_mode():
        for _ in range(reps):
            t = time.perf_counter()
            veto.blocked(predicted_depth(model.depth_head, token))
            times.append(time.perf_counter() - t)
    return 1e3 * statistics.median(times)


def latency_figures(reps: int, policy_threads: int | None, threads: int, sampler: str, compile: bool) -> None:
    """The per-decision latency lines of ``benchmarks/train.py`` (its ``--latency-only`` prints these alone)."""
    print(f"\nper-decision latency on CPU (256x256 frame -> action; median; policy threads "
          f"{policy_threads or threads}; NoMaD: {sampler}, beside the reference sampling path):")
    goals = {("nomad_pointgoal", "full"): "  (goal <= 100 ms; issue 32: <= 40 ms on a GPU node's CPU thread)", ("nomad_neg", "full"): "  (goal <= 200 ms)"}
    for name, what in (("vint_pointgoal", "1 pass"), ("nomad_pointgoal", "8 samples x 10 steps"),
                       ("nomad_neg", "2 x 8 samples x 10 steps")):
        for size in ("full", "small"):
            ms, ref = decision_ms(name, size, reps * 2, policy_threads, sampler)
            old = f"; reference path {ref:7.1f} ms, x{ref / ms:.2f}" if ref is not None else ""
            print(f"  {name:16s} {size:5s} {what:26s}: {ms:7.1f} ms{goals.get((name, size), '')}{old}")
            if compile and name != "nomad_neg":  # NoMaD-Neg: two NoMaD-PointGoal networks, twice the time
                compiled, plain = decision_ms(name, size, reps * 2, policy_threads, sampler, compile=True)
                print(f"  {name:16s} {size:5s} {'  policy.compile=true':26s}: {compiled:7.1f} ms; plain path "
                      f"{plain:7.1f} ms, x{plain / compiled:.2f}")
    for size in ("full", "small"):
        with intra_op_threads(policy_threads):
            parts = decision_parts(size, reps * 4)
        print(f"  {'nomad_pointgoal':16s} {size:5s} {'its parts':26s}: frame encoder {parts['encoder']:.1f} ms, condition "
              f"and FiLM biases {parts['condition']:.1f}, {parts['steps']} denoising steps {parts['denoise']:.1f} "
              f"(in torch.profiler: matrix products {100 * parts['matmul_share']:.0f} % of their operator time, at "
              f"{parts['matmul_gflops']:.0f} GFLOP/s)")
    for name in ("vint_pointgoal", "nomad_pointgoal"):
        for size in ("full", "small"):
            with intra_op_threads(policy_threads):
                fast, module = encoder_ms(name, size, reps * 6)
            print(f"  {name:16s} {size:5s} {'frame encoder, one frame':26s}: {fast:7.1f} ms; module forward "
                  f"{module:7.1f} ms, x{module / fast:.2f}")
    for size in ("full", "small"):  # what policy.depth_veto adds to a forward decision (rule swept; band is cheaper)
        print(f"  {'nomad_pointgoal':16s} {size:5s} {'+ depth veto check (swept)':26s}: "
              f"{veto_check_ms(size, DepthVeto(0.5, 'swept', 90.0)):7.3f} ms per MOVE_FORWARD")


def latency_arguments(ap: argparse.ArgumentParser) -> None:
    """The options of :func:`latency_figures` (benchmarks/train.py's too)."""
    ap.add_argument("--threads", type=int, default=1,
                    help="torch intra-op threads (default 1: on a shared machine more threads spin-wait on each other)")
    ap.add_argument("--policy-threads", type=int, default=1,
                    help="intra-op threads of a policy decision (the policies' threads setting; 0: as --threads)")
    ap.add_argument("--quick", action="store_true", help="fewer repetitions")
    ap.add_argument("--sampler", choices=("ddpm", "ddim"), default="ddpm",
                    help="NoMaD's reverse process (policy.sampler)")
    ap.add_argument("--compile", action="store_true",
                    help="also time policy.compile=true decisions beside the plain path (each model compiles first: "
                         "about a minute per network on one core)")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    latency_arguments(ap)
    args = ap.parse_args()
    torch.set_num_threads(args.threads)
    print(f"torch {torch.__version__}, {args.threads} thread(s)")
    latency_figures(3 if args.quick else 10, args.policy_threads or None, args.threads, args.sampler, args.compile)


if __name__ == "__main__":
    main()
