"""Compiling (or loading) RVN's numba kernels once, before work that starts many processes at once (node.py's rows,
the test suite's workers), which would otherwise each compile them side by side until one had cached them
(`rvn_data.numba_note` says where they are cached and whether they are)."""
from __future__ import annotations

import contextlib
import io
import tempfile

import numpy as np

from rvn_data.benchmark.goal_pool import GoalPool, PoolSampler
from rvn_data.config import load_config
from rvn_data.conventions import Action, AgentConfig
from rvn_data.gen.run import generate
from rvn_data.navmesh import NavMesh, NavMeshSettings
from rvn_data.scenes import load_scene
from rvn_data.sim import Simulator


def warm_kernels() -> None:
    """Compile (or load) the kernels rvn-gen and an episode run, here and once: two one-trajectory rvn-gen runs on one
    scene at 32x32 in a temporary folder, ray casting then ``renderer=auto`` (gl's culling kernel where EGL renders),
    then a random walk of the simulator (collisions slide), a shortest path and a goal pool's draw (rvn-rl's resets) on
    that scene. Cold, about 25 s on a 2-core CPU; cached, about 2 s. The navmesh profiles' own kernels
    (``navmesh.profile=recast``, Detour files) are left to their first use."""
    with tempfile.TemporaryDirectory() as tmp:
        for renderer in ("raycast", "auto"):
            cfg = load_config("gen", [f"out_dir={tmp}/{renderer}", "progress=false", "scenes.num_scenes=1",
                                      "trajectories_per_scene=1", "camera.width=32", "camera.height=32",
                                      f"renderer={renderer}"])
            with contextlib.redirect_stdout(io.StringIO()):
                report = generate(cfg)
            if report.status:
                errors = [r.error for r in report.results if r.error]
                raise RuntimeError(f"warming numba's kernels: rvn-gen failed: {errors}")
    navmesh = NavMesh.build(load_scene("procedural:train/0"), NavMeshSettings())
    rng = np.random.default_rng(0)
    sim = Simulator(navmesh, AgentConfig())
    sim.reset(navmesh.sample(rng), 0.0)
    for a in rng.choice([Action.MOVE_FORWARD, Action.MOVE_FORWARD, Action.TURN_LEFT], size=200):
        sim.step(Action(int(a)))
    navmesh.shortest_path(navmesh.sample(rng), navmesh.sample(rng))
    PoolSampler(navmesh, GoalPool.build(navmesh, 2, 0, 0)).sample(navmesh.sample(rng), rng, 0.0, np.inf)
