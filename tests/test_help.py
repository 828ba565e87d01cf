"""Each tool's --help says what the command does and its main knobs (not Hydra's generic
page); the first-compile note appears exactly while numba's cache lacks the kernels."""
import os
import subprocess
import sys

import pytest

from rvn_data.numba_note import kernels_cached, note_first_compile


@pytest.mark.parametrize("tool,module,knob", [
    ("rvn-gen", "rvn_data.gen.cli", "trajectories_per_scene"),
    ("rvn-train", "rvn_il.train.cli", "data.root"),
    ("rvn-eval", "rvn_data.benchmark.cli", "policy.checkpoint_path"),
    ("rvn-rl", "rvn_rl.cli", "train.total_steps"),
])
def test_help_describes_the_tool(tool, module, knob):
    r = subprocess.run([sys.executable, "-m", module, "--help"], capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    assert r.stdout.startswith(f"{tool}: "), r.stdout[:200]
    assert "powered by Hydra" not in r.stdout and knob in r.stdout
    assert "base_train" not in r.stdout and "base_eval" not in r.stdout  # schema entries are no choices



def test_commands_load_torchs_compiler_only_when_asked():
    """torch.compile's inductor costs a second at import: the command modules and the policy loader import it
    only when train.compile / policy.compile is set (rvn_il.models.compiled)."""
    code = ("import sys, rvn_il.train.cli, rvn_il.policies, rvn_data.benchmark.cli, rvn_rl.cli; "
            "print(sorted(m for m in sys.modules if m.startswith('torch._inductor')))")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    assert r.stdout.strip() == "[]", r.stdout[:300]


def test_command_modules_load_torch_only_to_work():
    """torch (~2 s to import) loads after the override check and --help: a typo'd setting is answered in about a
    second by every Hydra command (rvn-train and rvn-rl import their trainers when they start training)."""
    code = ("import sys, rvn_data.gen.cli, rvn_data.benchmark.cli, rvn_il.train.cli, rvn_rl.cli; "
            "print('torch' in sys.modules)")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert r.returncode == 0 and r.stdout.strip() == "False", r.stdout + r.stderr[-2000:]


def test_scene_info_works_without_an_argument():
    r = subprocess.run([sys.executable, "-m", "rvn_data.cli.scene", "info", "--json"], capture_output=True,
                       text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    assert '"procedural:train/0"' in r.stdout


def test_first_compile_note(tmp_path, monkeypatch, capsys):
    import numba

    monkeypatch.setattr(numba.config, "CACHE_DIR", str(tmp_path))
    assert not kernels_cached() and note_first_compile("rvn-gen")
    assert "compiling the numba kernels" in capsys.readouterr().out
    code = ("import numpy as np; from rvn_data.navmesh import kernels as K; "
            "K.clearance_at(np.zeros((1, 6), np.int64), np.zeros(1), 0.0, 0.0, 0.1, 0, 0.0, 0.0)")
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path)}
    subprocess.run([sys.executable, "-c", code], check=True, env=env, timeout=300)
    assert kernels_cached() and not note_first_compile("rvn-gen")
