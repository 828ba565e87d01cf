"""benchmarks/README.md lists every benchmark script, and names none that is gone: the README's pointer to the
benchmarks is that list, so a script added or renamed without it would be one nobody finds."""
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
