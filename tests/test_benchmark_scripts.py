"""The benchmark scripts themselves: benchmarks/README.md lists every one and names none that is gone (the README's
pointer to the benchmarks is that list, so a script added or renamed without it would be one nobody finds), and
decision.py's breakdown of a NoMaD decision measures the parts the policy runs."""
from __future__ import annotations

import re
from pathlib import Path

BENCHMARKS = Path(__file__).resolve().parents[1] / "benchmarks"


def test_benchmarks_readme_lists_every_script():
    text = (BENCHMARKS / "README.md").read_text()
    named = set(re.findall(r"`([\w.]+\.(?:py|sh|mjs))`", text))
    scripts = {p.name for p in BENCHMARKS.iterdir() if p.suffix in (".py", ".sh", ".mjs")}
    assert scripts - named == set(), f"benchmarks/README.md does not list {sorted(scripts - named)}"
    assert named - scripts == set(), f"benchmarks/README.md names {sorted(named - scripts)}, which are not in benchmarks/"


def test_decision_parts_of_a_nomad_decision(monkeypatch):
    """One frame through the encoder, the condition with the FiLM biases, and the model's denoising steps: each part
    timed, and the profiled steps' matrix products a share of their operator time with a rate from their FLOPs."""
    monkeypatch.syspath_prepend(str(BENCHMARKS))
    import decision

    from rvn_il.models import load_model_config

    parts = decision.decision_parts("small", reps=2)
    assert set(parts) == {"encoder", "condition", "denoise", "matmul_share", "matmul_gflops", "steps"}
    assert parts["steps"] == load_model_config("nomad_pointgoal", "small")["num_diffusion_iters"]
    assert all(parts[k] > 0 for k in ("encoder", "condition", "denoise", "matmul_gflops"))
    assert 0 < parts["matmul_share"] < 1
