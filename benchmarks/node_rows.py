"""The rows of benchmarks/node.py, one generator per row group of issue 32 (RL's in node_rl.py), each built on the
other benchmarks' functions (render.py, gen.py, train.py, rl.py) and yielding row dicts as they are measured
(node.py writes the table after each, so a run cut short keeps every row it finished). ``plan`` holds
the sizes and time budget (node.py's `make_plan`): every figure is timed for ``plan.seconds`` after
its warm-up."""
from __future__ import annotations

import contextlib
import math
import tempfile
import traceback
from collections.abc import Iterator
from pathlib import Path

from node_report import HABITAT, GpuBusy
from rvn_data.worker_threads import environ

NO_CUDA = "no CUDA on this machine (a GPU row)"


def row(group: int, key: str, label: str, unit: str, goal_key: str | None = None, value: float | None = None,
        settings: str = "", baseline: str = "", gpu_busy: float | None = None, skipped: str | None = None,
        profile: str | None = None) -> dict:
    """One row of the table; ``profile``: torch.profiler's operator table of the row (node.py --profile)."""
    return dict(group=group, key=key, label=label, value=value, unit=unit, goal_key=goal_key, settings=settings,
                baseline=baseline, gpu_busy=gpu_busy, skipped=skipped, error=None, profile=profile)


def failed_row(group: int, key: str, label: str, unit: str, err: Exception) -> dict:
    """The row ``key`` that raised ``err``, its error the exception's type and first line (the traceback printed to
    stderr): the table says what failed and the rows after it still run."""
    traceback.print_exc()
    failed = row(group, key, label, unit)
    failed["error"] = f"{type(err).__name__}: {str(err).strip().splitlines()[0] if str(err).strip() else ''}"
    return failed


@contextlib.contextmanager
def shared_cores(processes: int):
    """The cores shared between ``processes`` render workers as between rvn-eval's workers (software GL's
    LP_NUM_THREADS, OpenMP/BLAS: `rvn_data.worker_threads`), unless set by the user; one process: as it is."""
    if processes <= 1:
        yield
        return
    from rvn_data.worker_threads import threads_per_worker, worker_threads

    with worker_threads(threads_per_worker(processes)):
        yield


# NVIDIA's GL driver waits for the GPU with sched_yield() by default, a spin that keeps a core busy; usleep(0) frees it
# for the other workers (the driver's README, "OpenGL environment variable settings")
GL_USLEEP = {"__GL_YIELD": "USLEEP"}


def plain_then_compiled(measure, compile: bool) -> Iterator[tuple[str, object]]:
    """("plain", ``measure(False)``), then with ``compile`` ("compiled", ``measure(True)``), or ("failed", what
    failed) when the compiled path fails (the traceback goes to stderr): the plain figure is in the table before
    the minutes a first compile takes (a GPU node's time limit cut both compiled groups of the first run)."""
    yield "plain", measure(False)
    if compile:
        yield compiled_or_failed(lambda: measure(True))


def compiled_or_failed(measure_compiled) -> tuple[str, object]:
    """("compiled", ``measure_compiled()``), or ("failed", what failed; the traceback goes to stderr)."""
    try:
        return "compiled", measure_compiled()
    except Exception as e:
        traceback.print_exc()
        return "failed", f"{type(e).__name__}: {(str(e).strip().splitlines() or [''])[0][:200]}"


def render_rows(plan) -> Iterator[dict]:
    """1. renderer=gl and raycast, RGB + depth: frames/s with 1, 2 and cpu_count processes, one view per
    render call, then with ``plan.render_batches`` [(views per render_batch call, process counts), ...]."""
    from render import poses_for
    from rvn_data.render import CameraConfig, make_renderer
    from rvn_data.render.parallel import render_parallel
    from rvn_data.scenes.loader import load_scene

    scene = load_scene(plan.scene)
    camera = CameraConfig(width=plan.size, height=plan.size)
    poses = poses_for(scene, 200)
    runs = [(1, n) for n in plan.render_processes] + [(b, n) for b, counts in plan.render_batches for n in counts]
    for backend in plan.backends:
        goal = "render_gl" if backend == "gl" else None
        try:
            with make_renderer(scene, camera, backend) as r:
                info = r.info
        except RuntimeError as e:
            yield row(1, f"render_{backend}", f"renderer={backend}", "frames/s", goal, skipped=f"unavailable ({e})")
            continue
        for batch, n in runs:
            with shared_cores(n), GpuBusy() as busy:
                res = render_parallel(scene, camera, poses, backend, processes=n, return_images=False,
                                      seconds=plan.seconds, batch=batch)
            key = f"render_{backend}_{n}p" if batch == 1 else f"render_{backend}_b{batch}_{n}p"
            label = f"renderer={backend}, {n} process{'es' if n > 1 else ''}"
            yield row(1, key, label + (f", {batch} views per call" if batch > 1 else ""),
                      "frames/s", goal, res.frames_per_second,
                      f"{plan.size}² RGB+depth, {plan.scene} ({scene.num_triangles:,} triangles), {info}, "
                      f"cpu share {res.cpu_share:.2f}", HABITAT[1 if n == 1 else 5], busy.share)
        if backend == "gl":
            yield _scenes_row(plan, camera)


def _scenes_row(plan, camera, scenes: int = 4) -> dict:
    """gl frames/s of one view of each of ``scenes`` scenes per call in one process, as rvn-rl's `BatchEnv` of
    ``scenes`` envs renders them (`render_views`: one pass, one sync) beside each renderer's own `render`."""
    import time

    from render import poses_for
    from rvn_data.render import make_renderer, render_views
    from rvn_data.scenes.loader import load_scene

    specs = ([f"procedural:train/{k}" for k in range(scenes)] if plan.scene.startswith("procedural:")
             else [plan.scene] * scenes)
    renderers = [make_renderer(load_scene(spec), camera, "gl") for spec in specs]
    try:
        poses = [poses_for(r.scene, 64, seed=k) for k, r in enumerate(renderers)]

        def rate(together: bool, seconds: float) -> float:  # frames/s
            t0, i = time.perf_counter(), 0
            while time.perf_counter() - t0 < seconds or i < 2:
                views = [(r, *poses[k][i % 64]) for k, r in enumerate(renderers)]
                if together:
                    render_views(views)
                else:
                    for r, position, yaw in views:
                        r.render(position, yaw)
                i += 1
            return i * scenes / (time.perf_counter() - t0)

        rate(True, 0.0), rate(False, 0.0)  # warm-up
        with GpuBusy() as busy:
            together, alone = rate(True, plan.seconds / 2), rate(False, plan.seconds / 2)
    finally:
        for r in renderers:
            r.close()
    return row(1, f"render_gl_{scenes}scenes", f"renderer=gl, 1 process, one view of each of {scenes} scenes per call",
               "frames/s", None, together, f"{plan.size}² RGB+depth, render_views (one pass, as rvn-rl's BatchEnv); "
               f"each renderer's own render: {alone:.0f} frames/s, x{together / alone:.2f}; {specs[0]}..",
               gpu_busy=busy.share)


def gen_rows(plan) -> Iterator[dict]:
    """2. rvn-gen with cpu_count workers, renderer=auto: frames/s after set-up (end to end beside it), its time
    shares and each phase's ms per frame; with CUDA again with renderer=raycast (row ``gen_raycast``) and with gl whose
    driver waits without spinning (``gen_gl_usleep``): on the first GPU run planning took ~12 ms a frame in 16 gl
    workers, against 0.8 ms on a development CPU."""
    yield _gen_row(plan, "gen", "auto")
    if plan.cuda:
        yield _gen_row(plan, "gen_raycast", "raycast")
        yield _gen_row(plan, "gen_gl_usleep", "gl", GL_USLEEP)


def _gen_row(plan, key: str, renderer: str, env: dict | None = None) -> dict:
    import gen as gen_bench

    common = [f"camera.width={plan.size}", f"camera.height={plan.size}", f"renderer={renderer}"]
    with tempfile.TemporaryDirectory() as tmp, environ(env):
        warm = gen_bench.run(Path(tmp) / "warmup", ["scenes.num_scenes=1", "trajectories_per_scene=1", *common])
        t = gen_bench.timing(warm)  # per-frame cost without set-up sizes the run to plan.seconds
        per_frame = (sum(t.values()) - t["setup"]) / max(1, warm.frames)
        per_traj = warm.frames / max(1, sum(r.written for r in warm.results))
        # twice plan.seconds of frames per worker: the first trajectories' one-off costs (kernels, shaders) weigh less
        per_scene = max(1, min(1000, math.ceil(2 * plan.seconds / max(per_frame * per_traj, 1e-6))))
        w = plan.gen_workers
        with GpuBusy() as busy:
            rep = gen_bench.run(Path(tmp) / "run", [*common, f"workers={w}", f"scenes.num_scenes={w}",
                                                    f"trajectories_per_scene={per_scene}"])
    phases = gen_bench.timing(rep)
    total = sum(phases.values()) or 1.0
    # steady state: the frames over a worker's time after its set-up (start-up, scene, navmesh, renderer), which a
    # dataset of hundreds of trajectories per scene spreads thin; end to end (set-up included) beside it
    steady = rep.frames / max((total - phases["setup"]) / w, 1e-9)
    shares = ", ".join(f"{k} {100 * v / total:.0f}% ({1e3 * v / max(1, rep.frames):.2f} ms/frame)"
                       for k, v in phases.items())
    # the sizing run's worker had the machine to itself (its first trajectory's one-off costs included: an upper
    # bound): a phase slower per frame in w workers than there is slowed by their sharing the node
    alone = ", ".join(f"{k} {1e3 * v / max(1, warm.frames):.2f}" for k, v in t.items() if k != "setup")
    with_env = "".join(f", {k}={v}" for k, v in (env or {}).items())
    return row(2, key, f"rvn-gen, {w} workers, renderer={renderer}{with_env}, after set-up", "frames/s", "gen", steady,
               f"{plan.size}² JPEG, renderer {', '.join(gen_bench.backends(rep))}, {rep.frames} frames of {w} scenes "
               f"in {rep.seconds:.1f} s: {rep.frames / rep.seconds:.0f} frames/s end to end (start-up and set-up "
               f"included); time summed over workers: {shares}; one worker alone (the sizing run, {warm.frames} frames, "
               f"one-off costs included, ms/frame): {alone}", gpu_busy=busy.share)


def train_settings(plan) -> tuple[str, str, str]:
    """The training rows' (device, model.size, train.precision): full size in bf16 on a GPU, else the CPU's size."""
    return ("cuda", "full", "bf16") if plan.cuda else ("cpu", plan.cpu_model_size, "fp32")


def write_train_data(plan, folder: Path) -> Path:
    """The training rows' synthetic GNM dataset, written under ``folder``; its root."""
    from rvn_il.data.synthetic import write_synthetic_gnm

    trajectories, length = plan.train_data
    return write_synthetic_gnm(folder / "expert", trajectories, length, image_size=plan.train_image)


def decision_sizes(plan) -> dict[str, str]:
    """The decision rows' model.size of NoMaD, by where they run (gpu, cpu)."""
    return {"gpu": "full", "cpu": plan.decision_cpu_size}


def train_rows(plan) -> Iterator[dict]:
    """3. rvn-train's step (loader + forward + backward + AdamW [+ EMA]) of NoMaD and ViNT: samples/s, the plain
    step first, then with ``plan.compile`` the compiled one (row ``train_<model>_compiled``)."""
    import train as train_bench
    from rvn_il.models import load_model_config
    from rvn_il.policies.policy import intra_op_threads

    device, size, precision = train_settings(plan)
    with tempfile.TemporaryDirectory() as tmp:
        root = write_train_data(plan, Path(tmp))
        for name in ("nomad_pointgoal", "vint_pointgoal"):
            cfg = load_model_config(name, size)

            def measure(compiled: bool, mode: str = "default"):
                profiles, window = ({} if plan.profile else None), []
                with intra_op_threads(plan.train_threads), GpuBusy() as busy:
                    rate, steps, waiting = train_bench.steady_train_rate(
                        root, cfg, plan.train_batch, plan.seconds, device, precision, plan.loader_workers,
                        str(Path(tmp) / "cache"), compiled, profiles, compile_mode=mode, window=window)
                return rate, steps, waiting, busy.share_in(window), (profiles or {}).get("train")

            w, h = cfg["image_size"]

            def train_row(key: str, label: str, got, note: str) -> dict:
                rate, steps, waiting, busy, profile = got
                return row(3, key, f"rvn-train {name} ({device}){label}", "samples/s", f"train_{name}", rate,
                           f"model.size={size}, {w}x{h}, batch {plan.train_batch}, train.precision={precision}, "
                           f"{note}, {plan.loader_workers} loader workers, {plan.train_threads or 'all'} torch threads, "
                           f"{steps} steps timed, waiting for the loader {100 * waiting:.0f}% of the time, "
                           "synthetic GNM data", gpu_busy=busy, profile=profile)

            plain = measure(False)  # first: a compiled step is measured after minutes of compiling
            yield train_row(f"train_{name}", "", plain, "train.compile=false")
            for mode in plan.compile_modes if plan.compile else ():  # default: rvn-train's train.compile=true
                key, label = (f"train_{name}_compiled", ", train.compile=true") if mode == "default" else (
                    f"train_{name}_compiled_{mode}", f", train.compile=true, torch.compile mode {mode}")
                kind, got = compiled_or_failed(lambda: measure(True, mode=mode))
                if kind == "failed":
                    yield row(3, key, f"rvn-train {name} ({device}){label}", "samples/s", f"train_{name}",
                              skipped=f"the compiled step FAILED ({got})")
                else:
                    yield train_row(key, label, got, f"{label[2:]} (x{got[0] / plain[0]:.2f} the plain step)")


def decision_rows(plan) -> Iterator[dict]:
    """4. one act() of a NoMaD-PointGoal policy (8 samples x its diffusion steps): median ms, GPU and one CPU
    thread; the plain path first, then with ``plan.compile`` policy.compile (row ``decision_<where>_compiled``)."""
    import decision as decision_bench
    from rvn_il.models import load_model_config

    for where, size in decision_sizes(plan).items():
        steps = load_model_config("nomad_pointgoal", size)["num_diffusion_iters"]
        label = "NoMaD decision, GPU" if where == "gpu" else "NoMaD decision, one CPU thread"
        if where == "gpu" and not plan.cuda:
            yield row(4, "decision_gpu", label, "ms", "decision_gpu", skipped=NO_CUDA)
            continue

        def measure(compiled: bool):  # each path alone, as in a process of its own
            profiles, window = ({} if plan.profile else None), []
            with GpuBusy() as busy:
                ms, _ = decision_bench.decision_ms("nomad_pointgoal", size, 5, threads=1, reference=False,
                                                   seconds=plan.seconds, device="cuda" if where == "gpu" else "cpu",
                                                   compile=compiled, profiles=profiles, window=window)
            return ms, busy.share_in(window) if where == "gpu" else None, (profiles or {}).get("decision")

        plain = None
        for kind, got in plain_then_compiled(measure, plan.compile):
            if kind == "failed":
                yield row(4, f"decision_{where}_compiled", label + ", policy.compile=true", "ms", f"decision_{where}",
                          skipped=f"the compiled path FAILED ({got})")
                continue
            ms, busy, profile = got
            plain = plain or ms
            compiled = kind == "compiled"
            yield row(4, f"decision_{where}" + ("_compiled" if compiled else ""),
                      label + (", policy.compile=true" if compiled else ""), "ms", f"decision_{where}", ms,
                      f"model.size={size}, 8 samples x {steps} steps, 256x256 frame -> action, "
                      f"policy.compile={str(compiled).lower()}" + (f" (x{plain / ms:.2f} faster than plain)" if compiled
                                                                   else "") + ", median after warm-up",
                      gpu_busy=busy, profile=profile)
