"""Issue 35 item 5: the README's "Using it" block runs in order on a fresh clone. Without running the
work, every command's config is composed as the command would compose it (``--cfg job --resolve``:
the same override check, schemas and defaults), and the test fails on an unknown key, two lines
writing into one out_dir, or a line that reads a path (a dataset, a checkpoint, runs to report) that no
earlier line creates. Paths outside the repository (``/data/hm3d``, ``/path/to/scene.glb``, a user's
``scan.glb``) are the user's."""
from __future__ import annotations

import os
import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

REPO = Path(__file__).resolve().parents[1]
ENV = {**os.environ, "OMP_NUM_THREADS": "1"}
HYDRA = {"rvn-gen": "rvn_data.gen.cli", "rvn-eval": "rvn_data.benchmark.cli", "rvn-train": "rvn_il.train.cli",
         "rvn-rl": "rvn_rl.cli"}
READS = {"rvn-train": ("data.root", "data.negative_root", "data.val_root", "data.depth_root", "train.expert_from",
                       "data.datasets"),
         "rvn-eval": ("policy.checkpoint_path", "policy.ensemble"), "rvn-rl": ("depth.model_path",)}
USER_FILES = ("/data/", "/path/", "scan.glb")


def using_it_block() -> list[str]:
    """The commands of the README's "Using it" bash block, one per entry (``a && b`` gives two)."""
    text = (REPO / "README.md").read_text()
    block = text.split("## Using it", 1)[1].split("```bash", 1)[1].split("```", 1)[0]
    out = []
    for line in block.splitlines():
        line = line.split("  #")[0].strip()
        if not line or line.startswith("#"):
            continue
        out += [part.strip() for part in line.split("&&")]
    return out


def command(line: str) -> tuple[str, list[str]]:
    """(tool, arguments): console scripts as they are; ``torchrun ... -m <module>`` and ``python -m <module>`` by
    module; ``ENV=... bash jobs/x.sh OUT`` as ``bash``; placeholders (``...``) dropped."""
    words = [w for w in shlex.split(line) if w != "..."]
    while words and re.fullmatch(r"[A-Z_]+=.*", words[0]):  # quoted values may hold spaces: SEEDS="0 1"
        words = words[1:]
    if words[0] in ("torchrun", "python") and "-m" in words:
        i = words.index("-m")
        module = words[i + 1]
        tool = next((k for k, v in HYDRA.items() if v == module), module)
        return tool, words[i + 2:]
    if words[0] == "python":  # python benchmarks/x.py
        return words[1], words[2:]
    return words[0], words[1:]


def composed(tool: str, args: list[str], cwd: Path) -> dict:
    if tool == "rvn_rl.depth.cli":
        from dataclasses import asdict

        from rvn_rl.depth.cli import compose

        return asdict(compose(args))
    from rvn_data.cli.overrides import first_values

    args = first_values([a for a in args if a != "-m"])  # one job of a sweep, Hydra's own settings left out
    proc = subprocess.run([sys.executable, "-m", HYDRA[tool], *args, "--cfg", "job", "--resolve"], capture_output=True,
                          text=True, env=ENV, cwd=cwd, timeout=300)
    assert proc.returncode == 0, f"{tool} {shlex.join(args)}\n{proc.stderr[-2000:]}"
    return yaml.safe_load(proc.stdout)


def get(cfg: dict, key: str):
    for part in key.split("."):
        cfg = cfg.get(part) if isinstance(cfg, dict) else None
    return cfg


def norm(path: str) -> str:
    return os.path.normpath(str(path))


@pytest.mark.slow
def test_readme_using_it_block_runs_in_order(tmp_path):
    made: dict[str, str] = {}  # out_dir or file -> the line that makes it

    def exists(path: str) -> bool:
        p = norm(path)
        return any(p == m or m.startswith(p + os.sep) for m in made) or str(path).startswith(USER_FILES)

    lines = using_it_block()
    assert len(lines) > 30
    for line in lines:
        tool, args = command(line)
        if tool in HYDRA or tool == "rvn_rl.depth.cli":
            cfg = composed(tool, args, tmp_path)
            for key in READS.get(tool, ()):
                value = get(cfg, key)
                for path in ([] if value is None else value if isinstance(value, list) else [value]):
                    path = path["root"] if isinstance(path, dict) else path  # data.datasets: its entries' folders
                    assert exists(path), f"{line!r} reads {key}={path}, which no earlier line creates"
            out = norm(cfg["out_dir"])
            assert out not in made, f"{line!r} writes into {out}, as {made[out]!r} does"
            made[out] = line
        elif tool in ("rvn_il.eval.agreement", "rvn_data.benchmark.report", "rvn_data.benchmark.trace_maps"):
            paths = [a for i, a in enumerate(args) if not a.startswith("-") and (i == 0 or not args[i - 1].startswith("-"))]
            for path in paths:
                assert exists(path), f"{line!r} reads {path}, which no earlier line creates"
            if "-o" in args:
                made[norm(args[args.index("-o") + 1])] = line
        elif tool == "rvn-scene":
            if "--navmesh" in args:
                path = args[args.index("--navmesh") + 1]
                assert exists(path), f"{line!r} reads {path}, which no earlier line creates"
            if "-o" in args:
                made[norm(args[args.index("-o") + 1])] = line
        elif tool == "bash":
            if len(args) > 1:
                made[norm(args[1])] = line  # jobs/<recipe>.sh OUT
        else:
            assert tool in ("less",) or tool.startswith("benchmarks/"), f"unknown tool in {line!r}"
