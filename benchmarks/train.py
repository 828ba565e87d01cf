"""Figures of issue 6 (rvn-train): loader samples/s from the packed cache (2 workers),
training samples/s on CPU per model (full size, batch 8; small size, batch 32; rvn-train's NHWC
encoder against NCHW), and
per-decision latency on CPU of the ViNT, NoMaD (8 samples x 10 steps) and NoMaD-Neg (2 x 8)
policies (and what ``policy.depth_veto`` adds to a forward decision), NoMaD's beside the reference sampling path (``predict(fast=False)``: module forward
and diffusers' ``DDPMScheduler.step``, the implementation before issue 15) as a ratio. Goals:
loader >= 2,000 samples/s; a NoMaD decision <= 100 ms; a NoMaD-Neg decision <= 200 ms.

    python benchmarks/train.py [--threads N] [--policy-threads 1] [--workers 2] [--quick] [--latency-only]

``--threads`` sets torch's intra-op threads; a policy decision runs with at most
``--policy-threads`` of them (the policies' ``threads`` setting, default 1; 0: torch's setting).

Runs on a synthetic GNM dataset written to a temporary folder; random-init weights (speed
does not depend on them). The machine is shared: numbers are as measured. The decision figures are
benchmarks/decision.py's (node.py's decision rows call it too).
"""
from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from pathlib import Path

import torch
from torch.utils.data import BatchSampler, DataLoader

from rvn_il.data import BatchView, EpochSampler, make_dataset
from rvn_il.data.synthetic import write_synthetic_gnm
from rvn_il.models import build_model, load_model_config
from rvn_il.models.compiled import compile_for_training

from decision import compile_alone, in_turns, latency_arguments, latency_figures


def loader_rate(root: Path, cfg: dict, workers: int, batch: int, batches: int) -> float:
    ds = make_dataset(root, cfg, {"progress": False})
    sampler = BatchSampler(EpochSampler(len(ds)), batch, drop_last=True)
    dl = DataLoader(BatchView(ds), batch_size=None, sampler=sampler, num_workers=workers,
                    persistent_workers=workers > 0, prefetch_factor=4 if workers else None)
    it = iter(dl)
    next(it)
    t, n = time.perf_counter(), 0
    for _ in range(batches):
        n += len(next(it)["distance"])
    rate = n / (time.perf_counter() - t)
    del it, dl
    return rate


def train_rate(root: Path, cfg: dict, batch: int, steps: int, channels_last: bool = True) -> float:
    """Samples/s of training steps; ``channels_last`` as rvn-train (NHWC encoder weights), else NCHW."""
    ds = make_dataset(root, cfg, {"progress": False})
    torch.manual_seed(0)
    model = build_model(cfg).train()
    if channels_last:
        model.use_channels_last()
    opt = torch.optim.AdamW(model.parameters(), lr=1e-4)
    gen = torch.Generator().manual_seed(0)
    times = []
    for s in range(steps + 1):
        b = ds.get_batch(range(s * batch, (s + 1) * batch))
        t = time.perf_counter()
        loss = model(b, gen)["loss"]
        opt.zero_grad()
        loss.backward()
        opt.step()
        times.append(time.perf_counter() - t)
    return batch / statistics.median(times[1:])


def steady_train_rate(root: Path, cfg: dict, batch: int, seconds: float, device: str = "cpu",
                      precision: str = "fp32", workers: int = 0, cache_dir: str | None = None,
                      compile: bool = False, profiles: dict | None = None,
                      channels_last: bool = True, compile_mode: str = "default",
                      window: list | None = None) -> tuple[float, int, float]:
    """(samples/s, steps timed, share of the timed wall time spent waiting for the loader's next batch) of
    rvn-train's step in steady state: its DataLoader (``workers`` processes,
    pinned memory on a GPU, uint8 frames), channels-last model on ``device`` (compiled with ``compile``, as
    train.compile), bf16 autocast with ``precision=bf16``, AdamW (fused on a GPU) and, where the model trains
    one (NoMaD), the EMA; no host sync inside a step; timed for ``seconds`` after a warm-up
    (at least 3 steps and a fifth of ``seconds``, until a step takes at most 1.5 x the fastest one
    so far, or ``seconds`` have passed). With ``profiles`` (a dict), 3 more steps are profiled after the timing
    into ``profiles["train"]`` (`op_profile.op_table`). ``channels_last=False`` keeps the encoder NCHW (rvn-train
    makes it NHWC): on the second GPU run NoMaD's NCHW step was 0.89x as fast, although on CUDA torch's group_norm
    copies a channels-last input to NCHW (aten::copy_ was 36% of its step's GPU time on the first GPU run).
    ``compile_mode``: as `compile_for_training`'s (``reduce-overhead``: CUDA graphs; each step then marks its
    beginning for them). ``window`` (a list) receives the timed steps' [start, end] (``time.perf_counter``), for
    `node_report.GpuBusy.share_in`."""
    from op_profile import op_table, phase
    from rvn_il.train.ema import EMA
    from rvn_il.train.choices import fused_on

    dev = torch.device(device)
    ds = make_dataset(root, cfg, {"progress": False, "cache_dir": cache_dir})
    torch.manual_seed(0)
    model = build_model(cfg).to(dev)
    if channels_last:
        model.use_channels_last()
    model.train()
    opt = torch.optim.AdamW(model.parameters(), lr=1e-4, fused=fused_on(dev))
    if compile:
        compile_alone()
        compile_for_training(model, compile_mode)
    graphs = compile and compile_mode == "reduce-overhead"
    ema = EMA(model, float(cfg.get("ema_power", 0.75))) if cfg.get("ema", False) else None
    sampler = BatchSampler(EpochSampler(len(ds)), batch, drop_last=True)
    loader = DataLoader(BatchView(ds), batch_size=None, sampler=sampler, num_workers=workers,
                        pin_memory=dev.type == "cuda", persistent_workers=workers > 0,
                        prefetch_factor=4 if workers else None)
    gen = torch.Generator(device=dev).manual_seed(0)
    sync = torch.cuda.synchronize if dev.type == "cuda" else (lambda: None)
    steps, t_start, t_step, fastest, waited = 0, None, time.perf_counter(), float("inf"), 0.0
    warm_until, warm_limit = t_step + seconds / 5, t_step + seconds
    batches = iter(loader)

    def step() -> float:  # one step; returns the seconds spent waiting for the batch
        t_wait = time.perf_counter()
        with torch.profiler.record_function("loader wait"):
            b = next(batches)
        wait = time.perf_counter() - t_wait
        if graphs:  # a new step: the last step's graph outputs may be overwritten
            torch.compiler.cudagraph_mark_step_begin()
        with phase("to device"):
            b = {k: v.to(dev, non_blocking=True) for k, v in b.items()}
        with phase("forward"), torch.autocast(dev.type, dtype=torch.bfloat16, enabled=precision == "bf16"):
            loss = model(b, gen)["loss"]
        with phase("backward"):
            opt.zero_grad(set_to_none=True)
            loss.backward()
        with phase("optimizer"):
            opt.step()
        if ema is not None:
            with phase("ema"):
                ema.update(model)
        return wait

    while True:
        wait = step()
        if t_start is not None:
            waited += wait
        steps += 1
        if t_start is None:  # warm-up: 3 steps, a fifth of ``seconds``, and the last step near the fastest one
            sync()
            now = time.perf_counter()
            last, t_step = now - t_step, now
            fastest = min(fastest, last)
            if steps >= 3 and now >= warm_until and (last <= 1.5 * fastest or now >= warm_limit):
                t_start, steps = now, 0
        elif time.perf_counter() - t_start >= seconds:
            sync()
            break
    wall = time.perf_counter() - t_start
    if window is not None:
        window[:] = [t_start, t_start + wall]
    if profiles is not None:
        profiles["train"] = op_table(lambda: [step() for _ in range(3)], dev.type == "cuda")
    batches = loader = None  # the loader's workers end here (step() closes over batches)
    return steps * batch / wall, steps, waited / wall


def data_figures(workers: int, reps: int) -> None:
    """Loader and training rates on a synthetic GNM dataset in a temporary folder."""
    with tempfile.TemporaryDirectory() as tmp:
        root = write_synthetic_gnm(Path(tmp) / "expert", 40, 40, image_size=256)
        print("\nloader (packed HDF5 cache, batch 256):")
        for name in ("vint_pointgoal", "nomad_pointgoal"):
            cfg = load_model_config(name)
            w, h = cfg["image_size"]
            rate = loader_rate(root, cfg, workers, 256, reps)
            print(f"  {name:16s} {w}x{h}, {cfg['context_size'] + 1} frames: {rate:8.0f} samples/s  (goal >= 2000)")
        print("\ntraining on CPU (forward + backward + AdamW):")
        for name in ("vint_pointgoal", "nomad_pointgoal"):
            for size, batch in (("full", 8), ("small", 32)):
                rate = train_rate(root, load_model_config(name, size), batch, reps)
                nchw = train_rate(root, load_model_config(name, size), batch, reps, channels_last=False)
                print(f"  {name:16s} {size:5s} batch {batch:3d}: {rate:8.1f} samples/s  (NCHW encoder: {nchw:6.1f}, "
                      f"x{rate / nchw:.2f})")
        print("  (nomad_neg trains two nomad_pointgoal models one after the other: half the nomad rate)")
    ema, baseline = ema_ms(reps * 3)
    print(f"\nEMA update, NoMaD full (rvn-train's EMA, parameters found once): {ema:.2f} ms; reading a state_dict "
          f"each update (before 2026-11-27): {baseline:.2f} ms, x{baseline / ema:.2f}")


def ema_ms(reps: int) -> tuple[float, float]:
    """Median ms of `EMA.update` on NoMaD full, and of the same update reading ``model.state_dict()`` each time (its
    form before the third GPU run, where it took ~11 ms of host time a step), timed in turns."""
    from rvn_il.train.ema import EMA

    model = build_model(load_model_config("nomad_pointgoal", "full")).train()
    ema, old = EMA(model), EMA(model)

    @torch.no_grad()
    def by_state_dict() -> None:
        old.step += 1
        d, floats_s, floats_m = old.decay(), [], []
        for k, v in model.state_dict().items():
            if v.dtype.is_floating_point:
                floats_s.append(old.shadow[k])
                floats_m.append(v.detach())
            else:
                old.shadow[k].copy_(v)
        torch._foreach_lerp_(floats_s, floats_m, 1.0 - d)

    return in_turns(lambda: ema.update(model), by_state_dict, reps=reps, warm=1)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    latency_arguments(ap)
    ap.add_argument("--workers", type=int, default=2, help="DataLoader workers for the loader figure")
    ap.add_argument("--latency-only", action="store_true",
                    help="only the per-decision latency figures (as benchmarks/decision.py)")
    args = ap.parse_args()
    torch.set_num_threads(args.threads)
    reps = 3 if args.quick else 10
    print(f"torch {torch.__version__}, {args.threads} thread(s), loader workers {args.workers}")
    if not args.latency_only:
        data_figures(args.workers, reps)
    latency_figures(reps, args.policy_threads or None, args.threads, args.sampler, args.compile)


if __name__ == "__main__":
    main()
