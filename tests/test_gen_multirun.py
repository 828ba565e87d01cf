"""rvn-gen multirun through hydra-submitit-launcher's local launcher (real subprocesses):
two shards, finalised by the last one, equal byte for byte to a single-process run."""
import hashlib
import subprocess
import sys
from pathlib import Path
import pytest

pytestmark = pytest.mark.slow  # end-to-end runs of the CLIs; the fast tier is -m "not slow"

TINY = ["scenes.num_scenes=2", "trajectories_per_scene=1", "camera.width=32", "camera.height=32", "progress=false"]


def hashes(root: Path) -> dict[str, str]:
    return {p.relative_to(root).as_posix(): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(root.rglob("*"))
            if p.is_file() and not any(s.startswith(".") for s in p.relative_to(root).parts)}


def test_two_shards_with_submitit_local(tmp_path):
    sharded, single = tmp_path / "sharded", tmp_path / "single"
    proc = subprocess.run([sys.executable, "-m", "rvn_data.gen.cli", "-m", "hydra/launcher=local",
                           "shard_index=0,1", "num_shards=2", f"out_dir={sharded}", *TINY],
                          capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    logs = list((sharded / ".rvn" / "multirun" / ".submitit").glob("*/*_log.out"))
    assert len(logs) == 2  # two real jobs
    assert {p.name for p in (sharded / ".rvn" / "scenes").iterdir()} == {"proc_train_0000.json", "proc_train_0001.json"}
    names = sum(((sharded / "data_splits" / "rvn_expert" / s / "traj_names.txt").read_text().split()
                 for s in ("train", "test")), [])
    assert sorted(names) == ["proc_train_0000_expert_0000", "proc_train_0001_expert_0000"]
    # merging again is idempotent, and the result equals a single-process run
    before = hashes(sharded)
    proc = subprocess.run([sys.executable, "-m", "rvn_data.gen.cli", "mode=merge", f"out_dir={sharded}", *TINY],
                          capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr
    assert hashes(sharded) == before
    proc = subprocess.run([sys.executable, "-m", "rvn_data.gen.cli", f"out_dir={single}", *TINY],
                          capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr
    assert hashes(single) == before
