"""Shared test helpers: analytic box scenes and the real scene shipped with the project."""
from __future__ import annotations

import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import pytest
import trimesh

from rvn_data.cache_root import ENV as CACHE_ENV  # the run's shared cache root (share_cache_root)
from rvn_data.scenes.scene import Part, Scene

# the real apartment lives beside the checkout (../shared/scenes/), or where RVN_TEST_SCENE says
DREAM_APARTMENT = Path(os.environ.get(
    "RVN_TEST_SCENE", Path(__file__).resolve().parents[2] / "shared" / "scenes" / "dream_apartment.glb"))


# The files whose tests take longest on 2 cores, slowest first (each file's time under `-n auto --dist loadfile`,
# 2026-12-02: test_compiled ~160 s, test_rl ~145, test_node_benchmark ~140, test_experiment_smoke ~105, test_rl_ddppo
# ~100, test_real_sim_smoke ~90, then ten files of 30-55 s; 2026-12-05: test_node_benchmark's RL tests, ~65 s, moved
# to test_node_rl). xdist's loadfile hands files out in queue order, by
# default the files with the most tests first, which left one worker running a long file alone at the end
# (test_rl_ddppo, later test_rl: 75 s of one idle core). Longest first, the short files fill in behind, and the two
# workers end within seconds of each other. test_compiled leads: it needs none of numba's kernels (KERNEL_FREE), so
# on a fresh clone one worker runs it while the kernels compile (pytest_configure).
LONGEST_FIRST = ("test_compiled.py", "test_rl.py", "test_node_benchmark.py", "test_experiment_smoke.py",
                 "test_rl_ddppo.py", "test_real_sim_smoke.py", "test_node_rl.py", "test_eval.py", "test_il_train.py",
                 "test_agreement.py", "test_depth_aux.py", "test_gen_readback.py", "test_embodiment.py",
                 "test_il_datasets.py", "test_rl_depth.py", "test_cli_errors.py", "test_worker_threads.py",
                 "test_gen_repair.py", "test_report.py", "test_il_models.py", "test_cli_typos.py", "test_rl_vec_env.py",
                 "test_readme_block.py")
# Test files that call none of numba's kernels (torch.compile on synthetic frames): they start before the kernels are
# compiled; every other file's tests wait for them (pytest_runtest_setup)
KERNEL_FREE = ("test_compiled.py",)
# Set while pytest's main process compiles numba's kernels for the workers: the file that appears when it has ended
WARMING = "RVN_TEST_KERNELS_WARMING"
_WARM_UP = """import pathlib, sys
try:
    from rvn_data.warm_kernels import warm_kernels
    warm_kernels()
finally:
    pathlib.Path(sys.argv[1]).touch()
"""


# The environment of the tests' compiled training runs (rvn-train, rvn-rl with train.compile=true): inductor's scalar
# C++ kernels, each graph's in one translation unit, compiled without optimisation (tests/test_compiled.py says why)
QUICK_COMPILE_ENV = {"TORCHINDUCTOR_VEC_ISA_OK": "0", "TORCHINDUCTOR_CPP_WRAPPER": "1", "TORCHINDUCTOR_DEBUG_COMPILE": "1"}


def pytest_collection_modifyitems(config, items):
    """:data:`LONGEST_FIRST` first, the other files after them in their order (a stable sort)."""
    rank = {name: i for i, name in enumerate(LONGEST_FIRST)}
    items.sort(key=lambda item: rank.get(item.path.name, len(rank)))


def pytest_configure(config):
    """With xdist's workers (``-n``) and numba's kernels not cached yet (a fresh clone), compile them once, in a process
    of pytest's main process (`rvn_data.warm_kernels.warm_kernels`, 30-40 s on 2 cores), while the workers start.
    Otherwise each worker and each CLI process it starts compiles them side by side until one has cached them (on a
    2-core machine, fresh clones: 895 s of tests without this, 765 s with it, 823 s with the kernels cached
    beforehand). The workers' tests wait for it (:func:`pytest_runtest_setup`), those of :data:`KERNEL_FREE` files
    excepted, so one core runs test_compiled.py while the other compiles the kernels (before 2026-12-02 the workers
    started after them, one core idle meanwhile). A warm-up that fails leaves the tests to compile what they need, as
    before. xdist's queue takes the collection's order (:data:`LONGEST_FIRST`)."""
    if hasattr(config, "workerinput"):
        return  # a worker: the main process's cache root and warm-up are in its environment
    share_cache_root(config)
    if not getattr(config.option, "numprocesses", None):
        return
    config.option.loadscopereorder = False  # xdist's queue in the collection's order: LONGEST_FIRST's files first
    from rvn_data.numba_note import kernels_cached

    if not kernels_cached():
        done = Path(tempfile.mkdtemp(prefix="rvn-kernels-")) / "done"
        config.rvn_warm_up = subprocess.Popen([sys.executable, "-c", _WARM_UP, str(done)], stdout=subprocess.DEVNULL,
                                              stderr=subprocess.DEVNULL, env={**os.environ, "OMP_NUM_THREADS": "1"})
        config.rvn_warm_up_done = done
        os.environ[WARMING] = str(done)  # the workers start after this hook: they inherit it


def share_cache_root(config) -> None:
    """One cache root for the whole run (`RVN_CACHE_DIR`, rvn_data/cache_root.py), in a temporary folder that the run
    removes at its end: every test's runs and CLI processes, in every xdist worker, read the procedural scenes'
    navmeshes, goal pools and episode sets that an earlier test built (each keyed by what its content depends on, and
    built once by processes asking at once), instead of building them again under each test's out_dir. A user's own
    `RVN_CACHE_DIR` is not written into. Tests of where caches go (``<out_dir>/cache`` by default) take the variable
    away (`without_shared_cache`); tests giving ``cache_dir=`` or their own variable are as
    before. On the 2-core machine (2026-12-07, numba's kernels cached): the suite 880-922 s -> 724 s, its CPU time
    1,567-1,640 -> 1,286 s. What it costs: a refused command that built a cache before its checks would build it here,
    not in the out_dir that its test finds absent (the "nothing written" checks see the out_dir only)."""
    root = tempfile.mkdtemp(prefix="rvn-test-cache-")
    config.rvn_cache_root, config.rvn_cache_env_before = root, os.environ.get(CACHE_ENV)
    os.environ[CACHE_ENV] = root  # the workers start after this hook: they inherit it


def pytest_runtest_setup(item):
    """In a worker, while the main process compiles numba's kernels: wait for them (10 minutes at most), unless the
    test's file needs none (:data:`KERNEL_FREE`)."""
    done = os.environ.get(WARMING)
    if done and item.path.name not in KERNEL_FREE:
        deadline = time.monotonic() + 600
        while not os.path.exists(done) and time.monotonic() < deadline:
            time.sleep(0.2)
        os.environ.pop(WARMING)  # ended (or given up on): the next tests need not look


def pytest_unconfigure(config):
    """The shared cache root removed; the warm-up's process ended (stopped if a short run ended first) and its folder
    removed."""
    root = getattr(config, "rvn_cache_root", None)
    if root is not None:
        shutil.rmtree(root, ignore_errors=True)
        if config.rvn_cache_env_before is None:
            os.environ.pop(CACHE_ENV, None)
        else:
            os.environ[CACHE_ENV] = config.rvn_cache_env_before
    proc = getattr(config, "rvn_warm_up", None)
    if proc is not None:
        if proc.poll() is None:
            proc.kill()
        proc.wait()
        shutil.rmtree(config.rvn_warm_up_done.parent, ignore_errors=True)
        os.environ.pop(WARMING, None)


def without_shared_cache(env: dict) -> dict:
    """``env`` without `RVN_CACHE_DIR` (see `share_cache_root`), for a process whose caches a test looks for under its
    ``<out_dir>/cache``."""
    return {k: v for k, v in env.items() if k != CACHE_ENV}


def run_python(*args: str, check: bool = True, timeout: float = 600) -> subprocess.CompletedProcess:
    """``python ARGS`` (e.g. ``-m rvn_il.train.cli ...``) with one torch thread; asserts exit 0 unless
    ``check`` is false, showing the end of its output."""
    proc = subprocess.run([sys.executable, *args], capture_output=True, text=True, timeout=timeout,
                          env={**os.environ, "OMP_NUM_THREADS": "1"})
    if check:
        assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-3000:]
    return proc


def interrupted_copy(full: Path, part: Path, step: int = 2, member: str = "model") -> Path:
    """``part``: an rvn-train out_dir as a run interrupted after ``step`` would leave it (``full``'s config.yaml
    and its step checkpoint of ``member``, nothing later), to resume and compare with ``full``."""
    import shutil

    name = f"ckpt_{step:08d}"
    (part / member).mkdir(parents=True)
    shutil.copy(full / "config.yaml", part / "config.yaml")
    shutil.copytree(full / member / name, part / member / name)
    (part / member / "latest").write_text(name + "\n")
    return part


def run_recipe(script: str, out: Path, **env: str) -> subprocess.CompletedProcess:
    """``bash jobs/<script> OUT`` at SCALE=tiny with this interpreter, from OUT's parent folder; its trainings on one
    torch thread (``THREADS``; the recipes' default is 2), as the suite's processes each have about one core."""
    full = {**os.environ, "SCALE": "tiny", "PYTHON": sys.executable, "THREADS": "1", **env}
    return subprocess.run(["bash", str(Path(__file__).resolve().parents[1] / "jobs" / script), str(out)],
                          capture_output=True, text=True, timeout=900, env=full, cwd=out.parent)


def box_scene(boxes, name: str = "test") -> Scene:
    """A Scene of axis-aligned boxes given as (min xyz, max xyz) pairs, one part."""
    mesh = trimesh.util.concatenate([trimesh.creation.box(bounds=[lo, hi]) for lo, hi in boxes])
    return Scene(name, [Part("boxes", mesh.vertices, mesh.faces)], source="test")


def room_boxes(x: float = 4.0, z: float = 4.0, wall: float = 0.1, height: float = 2.5,
               origin=(0.0, 0.0)) -> list:
    """Floor (top at y=0) and four walls enclosing the interior [ox, ox+x] × [oz, oz+z]."""
    ox, oz = origin
    w = wall
    return [
        ((ox - w, -0.1, oz - w), (ox + x + w, 0.0, oz + z + w)),
        ((ox - w, 0.0, oz - w), (ox, height, oz + z + w)),
        ((ox + x, 0.0, oz - w), (ox + x + w, height, oz + z + w)),
        ((ox - w, 0.0, oz - w), (ox + x + w, height, oz)),
        ((ox - w, 0.0, oz + z), (ox + x + w, height, oz + z + w)),
    ]


@pytest.fixture
def rng() -> np.random.Generator:
    return np.random.default_rng(0)


@pytest.fixture(scope="session")
def dream_path() -> Path:
    if not DREAM_APARTMENT.exists():
        pytest.skip(f"{DREAM_APARTMENT} not available")
    return DREAM_APARTMENT
