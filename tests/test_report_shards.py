"""`python -m rvn_data.benchmark.report` on a folder of rvn-eval shards (copies of a committed run, no evaluation):
a shard that never finished is refused, naming it, rather than left out of its row."""
from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
RUN = REPO / "docs" / "results" / "2026-11-22_small_experiment" / "eval" / "oracle"


def report(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "rvn_data.benchmark.report", *args], capture_output=True, text=True,
                          timeout=300)


def test_an_unfinished_shard_below_a_folder_is_refused(tmp_path):
    """A shard stopped at its time limit holds episodes.jsonl but no metrics.json; find_runs collected only folders
    with metrics.json, so the report silently covered fewer episodes."""
    shutil.copytree(RUN, tmp_path / "eval" / "oracle" / "scenes_0")
    shutil.copytree(RUN, tmp_path / "eval" / "oracle" / "scenes_5")
    (tmp_path / "eval" / "oracle" / "scenes_5" / "metrics.json").unlink()
    proc = report(str(tmp_path / "eval"), "-o", str(tmp_path / "report.md"))
    assert proc.returncode == 2, proc.stderr
    assert proc.stderr.startswith(f"report: error: {tmp_path / 'eval' / 'oracle' / 'scenes_5'} has no metrics.json "
                                  "(the run is unfinished: rerun the same rvn-eval command") and proc.stderr.count("\n") == 1
    assert not (tmp_path / "report.md").exists()
    shutil.copy(RUN / "metrics.json", tmp_path / "eval" / "oracle" / "scenes_5")  # finished: the report is written
    proc = report(str(tmp_path / "eval"), "-o", str(tmp_path / "report.md"))
    assert proc.returncode == 0, proc.stderr
    assert (tmp_path / "report.md").is_file()
