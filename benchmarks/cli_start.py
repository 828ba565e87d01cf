"""Bad input answered at once: the seconds from a command's start to its one-line error for a typo'd setting and for
a value out of range, per Hydra command (rvn-gen, rvn-eval, rvn-train, rvn-rl), each a fresh Python process.

The commands check their overrides before anything loads torch (rvn-train and rvn-rl import their trainers when
they start training; rvn-rl runs every settings rule first, `RLConfig.validate`). The baseline is the same process
with torch imported before the command runs: a lower bound of what rvn-train's and rvn-rl's answers cost until
2026-11-29, when rvn-train's module imported its trainer and rvn-rl checked its values in the trainer, both with
torch (this script on main 02ddc9f, 2-core development VM: rvn-train's typo 1.80 s, rvn-rl's bad value 2.84 s;
now 0.44 and 0.61). rvn-gen and rvn-eval never loaded torch to check: their baseline shows torch's share for
scale. Nor need they load the planning chain (scipy.ndimage, numba) before their checks: since 2026-12-05 rvn-gen
imports its run module after the settings' checks and rvn-eval its trace maps when it draws them (medians of 5,
2-core development VM: rvn-gen's bad value 0.97 s on 1422775, 0.54 after; rvn-eval's typo 0.82 s, 0.47 after). The two run in turns after one untimed pair (disk cache); the medians and their ratio are printed. Nothing
is written: every case exits with status 2 before its out_dir is made.
Run: python benchmarks/cli_start.py [--rounds 5]
"""
from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
import tempfile
import time
import tomllib
from pathlib import Path

SCRIPTS = tomllib.loads((Path(__file__).resolve().parents[1] / "pyproject.toml").read_text())["project"]["scripts"]
CASES = [  # (command, what is wrong, the override)
    ("rvn-gen", "typo", "trajectories_per_scen=4"),
    ("rvn-gen", "value", "trajectories_per_scene=-1"),
    ("rvn-eval", "typo", "episodes.per_scen=4"),
    ("rvn-train", "typo", "train.max_step=3"),
    ("rvn-rl", "typo", "train.total_step=64"),
    ("rvn-rl", "value", "ppo.gamma=1.5"),
]
CHILD = ("import sys, runpy\nif {baseline}:\n    import torch\nsys.argv = sys.argv[1:]\n"
         "runpy.run_module({module!r}, run_name='__main__')")


def answer_s(command: str, override: str, out_dir: Path, baseline: bool) -> float:
    """Seconds until the command exits; asserts it answered with status 2, one line naming the setting."""
    code = CHILD.format(baseline=baseline, module=SCRIPTS[command].split(":")[0])  # the console script's module
    key = override.split("=", 1)[0]
    t0 = time.perf_counter()
    proc = subprocess.run([sys.executable, "-c", code, command, f"out_dir={out_dir}", override], capture_output=True,
                          text=True, timeout=120)
    seconds = time.perf_counter() - t0
    lines = [ln for ln in proc.stderr.splitlines() if ln.strip()]
    if proc.returncode != 2 or len(lines) != 1 or key not in lines[0] or out_dir.exists():
        raise SystemExit(f"{command} {override}: expected status 2 and one line, got {proc.returncode}: {proc.stderr}")
    return seconds


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--rounds", type=int, default=5, help="timed pairs per case (default 5)")
    args = parser.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        out_dir = Path(tmp) / "never_made"
        print(f"{'command':<10} {'bad input':<34} {'answer s':>9} {'torch first s':>14} {'ratio':>6}")
        for command, what, override in CASES:
            times = {False: [], True: []}
            for r in range(args.rounds + 1):
                for baseline in (False, True):
                    seconds = answer_s(command, override, out_dir, baseline)
                    if r:  # the first pair warms the disk cache
                        times[baseline].append(seconds)
            now, before = statistics.median(times[False]), statistics.median(times[True])
            print(f"{command:<10} {what + ': ' + override:<34} {now:>9.2f} {before:>14.2f} {before / now:>5.1f}x")


if __name__ == "__main__":
    main()
