"""Shared test helpers: analytic box scenes and the real scene shipped with the project."""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import trimesh

from rvn_data.scenes.scene import Part, Scene

# the real apartment lives beside the checkout (../shared/scenes/), or where RVN_TEST_SCENE says
DREAM_APARTMENT = Path(os.environ.get(
    "RVN_TEST_SCENE", Path(__file__).resolve().parents[2] / "shared" / "scenes" / "dream_apartment.glb"))


# The files whose tests take longest on 2 cores, slowest first (each file's time under `-n auto --dist loadfile`,
# 2026-11-29: test_rl ~165 s, test_experiment_smoke ~135, test_compiled ~125, test_real_sim_smoke ~115,
# test_node_benchmark ~105, test_rl_ddppo ~90, then ten files of 25-40 s). xdist's loadfile hands files out in queue
# order, by default the files with the most tests first, which left one worker running a long file alone at the end
# (test_rl_ddppo, later test_rl: 75 s of one idle core). Longest first, the short files fill in behind, and the two
# workers end within seconds of each other.
LONGEST_FIRST = ("test_rl.py", "test_experiment_smoke.py", "test_compiled.py", "test_real_sim_smoke.py",
                 "test_node_benchmark.py", "test_rl_ddppo.py", "test_eval.py", "test_il_train.py", "test_agreement.py",
                 "test_embodiment.py", "test_depth_aux.py", "test_rl_depth.py", "test_il_datasets.py",
                 "test_readme_block.py", "test_gen_readback.py", "test_worker_threads.py", "test_cli_errors.py",
                 "test_gen_repair.py")


# The environment of the tests' compiled training runs (rvn-train, rvn-rl with train.compile=true): inductor's scalar
# C++ kernels, each graph's in one translation unit, compiled without optimisation (tests/test_compiled.py says why)
QUICK_COMPILE_ENV = {"TORCHINDUCTOR_VEC_ISA_OK": "0", "TORCHINDUCTOR_CPP_WRAPPER": "1", "TORCHINDUCTOR_DEBUG_COMPILE": "1"}


def pytest_collection_modifyitems(config, items):
    """:data:`LONGEST_FIRST` first, the other files after them in their order (a stable sort)."""
    rank = {name: i for i, name in enumerate(LONGEST_FIRST)}
    items.sort(key=lambda item: rank.get(item.path.name, len(rank)))


def pytest_configure(config):
    """With xdist's workers (``-n``) and numba's kernels not cached yet (a fresh clone), compile them once here, in
    pytest's main process, before the workers start (`rvn_data.numba_note.warm_kernels`, ~25 s on 2 cores). Otherwise
    each worker and each CLI process it starts compiles them side by side until one has cached them. On a 2-core
    machine, fresh clones: 895 s of tests without this, 765 s with it (823 s with the kernels cached beforehand). A
    failure or time-out here is left to the tests, which compile what they need as before. xdist's queue takes the
    collection's order (:data:`LONGEST_FIRST`)."""
    if hasattr(config, "workerinput") or not getattr(config.option, "numprocesses", None):
        return
    config.option.loadscopereorder = False  # xdist's queue in the collection's order: LONGEST_FIRST's files first
    from rvn_data.numba_note import kernels_cached

    if not kernels_cached():
        try:
            subprocess.run([sys.executable, "-c", "from rvn_data.numba_note import warm_kernels; warm_kernels()"],
                           capture_output=True, timeout=600, env={**os.environ, "OMP_NUM_THREADS": "1"})
        except subprocess.TimeoutExpired:
            pass


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
