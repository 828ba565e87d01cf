"""`python -m rvn_data.benchmark.report` on outputs of the real rvn-eval CLI (random and oracle
policies, val scenes × 2 episodes × 3 goals, 32×32 camera; the oracle in two shards)."""
from __future__ import annotations

import json
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from PIL import Image

from rvn_data.benchmark.metrics import compute_metrics, read_records
from rvn_data.benchmark.report import find_runs, load_run, main as report_main, merge_shards

pytestmark = pytest.mark.slow  # end-to-end runs of the CLIs; the fast tier is -m "not slow"

SMALL = ["split=val", "episodes.num_scenes=1", "episodes.per_scene=2", "episodes.n_goals=3", "camera.width=32",
         "camera.height=32", "progress=false"]


def rvn_eval(tmp: Path, *overrides: str) -> None:
    proc = subprocess.run([sys.executable, "-m", "rvn_data.benchmark.cli", *SMALL, f"episodes.dir={tmp / 'episodes'}",
                           *overrides], capture_output=True, text=True, timeout=600, cwd=tmp)
    assert proc.returncode == 0, proc.stderr[-3000:]


@pytest.fixture(scope="module")
def runs(tmp_path_factory) -> Path:
    tmp = tmp_path_factory.mktemp("report")
    rvn_eval(tmp, "policy=oracle", "method=Oracle", f"out_dir={tmp / 'eval' / 'oracle'}")
    # a second shard of the oracle's evaluation: the next val scene
    rvn_eval(tmp, "policy=oracle", "method=Oracle", "episodes.first_scene=1", f"out_dir={tmp / 'eval' / 'oracle_b'}")
    # the random policy under a paper method's name exercises the paper-reference columns
    rvn_eval(tmp, "policy=random", "method=NoMaD-PointGoal", f"out_dir={tmp / 'eval' / 'random'}")
    return tmp


def report(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "rvn_data.benchmark.report", *args], capture_output=True, text=True,
                          timeout=300)


def test_report_from_eval_outputs(runs, tmp_path):
    out = tmp_path / "rep" / "report.md"
    proc = report(str(runs / "eval" / "oracle"), str(runs / "eval" / "random"), "-o", str(out), "--title", "Tiny")
    assert proc.returncode == 0, proc.stderr
    text = out.read_text()
    oracle = json.loads((runs / "eval" / "oracle" / "metrics.json").read_text())
    rand = json.loads((runs / "eval" / "random" / "metrics.json").read_text())
    assert text.startswith("# Tiny\n")
    # paper layout: our rows (val columns filled) then the paper's rows
    row = next(ln for ln in text.splitlines() if ln.startswith("| RVN (ours) | Oracle |"))
    assert f"| {oracle['SR_1']:.3f} | {oracle['E_G']:.2f} | {oracle['CPK']:.1f} |" in row
    assert "| IL (paper) | NoMaD-PointGoal | 0.758 | 4.01 | 32.5 | 0.752 | 3.69 | 35.7 | 0.751 | 4.52 | 31.0 |" in text
    # ours beside the paper: same method and split; no paper numbers for the oracle
    assert f"| NoMaD-PointGoal | Val | {rand['SR_1']:.3f} | 0.752 | {rand['E_G']:.2f} | 3.69 |" in text
    assert re.search(r"\| Oracle \| Val \| [0-9.]+ \|  \| [0-9.]+ \|  \|", text)
    # run details link the per-episode logs; every episode is listed
    assert "| Oracle | oracle | val | 1 × 2 | 3 | 2 |" in text
    links = re.findall(r"\]\(([^)]+)\)", text)
    assert any(x.endswith("eval/oracle/episodes.jsonl") for x in links)
    for link in links:
        assert (out.parent / link).is_file(), link
    for name in ("report_sr1.png", "report_cpk.png", "report_goals.png"):
        assert f"]({name})" in text
        with Image.open(out.parent / name) as im:
            assert im.format == "PNG" and im.size[0] > 300
    records = [json.loads(x) for x in (runs / "eval" / "oracle" / "episodes.jsonl").read_text().splitlines()]
    for rec in records:
        assert f"| {rec['episode_id']} | {rec['scene_id']} | {rec['goals_reached']} |" in text
    assert not list(out.parent.glob(".*tmp*"))


def test_folder_of_runs_and_load(runs):
    found = find_runs([runs / "eval"])
    assert [r.method for r in found] == ["Oracle", "Oracle", "NoMaD-PointGoal"]  # by folder: oracle, oracle_b, random
    r = load_run(runs / "eval" / "random")
    assert r.split == "val" and r.paper() == (0.752, 3.69, 35.7) and len(r.records) == r.metrics["episodes"] == 2
    assert load_run(runs / "eval" / "oracle").paper() is None


def test_bad_runs(runs, tmp_path):
    unfinished = tmp_path / "unfinished"
    shutil.copytree(runs / "eval" / "oracle", unfinished)
    (unfinished / "metrics.json").unlink()
    proc = report(str(unfinished), "-o", str(tmp_path / "r.md"))
    assert proc.returncode == 2 and "unfinished" in proc.stderr and "Traceback" not in proc.stderr
    assert not (tmp_path / "r.md").exists()
    torn = tmp_path / "torn"
    shutil.copytree(runs / "eval" / "oracle", torn)
    lines = (torn / "episodes.jsonl").read_text().splitlines()
    (torn / "episodes.jsonl").write_text(lines[0] + "\n")
    with pytest.raises(ValueError, match="holds 1 episodes but"):
        load_run(torn)
    assert report_main([str(tmp_path / "missing"), "-o", str(tmp_path / "r.md")]) == 2  # bad input: exit status 2 (rvn_data/cli/common.py)
    empty = tmp_path / "empty"
    empty.mkdir()
    with pytest.raises(ValueError, match="holds no rvn-eval output"):
        find_runs([empty])


def test_shards_are_merged(runs, tmp_path):
    shards = [runs / "eval" / "oracle", runs / "eval" / "oracle_b"]
    merged = merge_shards(find_runs([*shards, runs / "eval" / "random"]))
    assert [r.method for r in merged] == ["Oracle", "NoMaD-PointGoal"]
    records = read_records(shards[0] / "episodes.jsonl") + read_records(shards[1] / "episodes.jsonl")
    assert len({r["scene_id"] for r in records}) == 2 and len(merged[0].records) == 4
    expected = compute_metrics(records)
    assert {k: merged[0].metrics[k] for k in expected} == expected and merged[0].metrics["scenes"] == 2
    out = tmp_path / "report.md"
    assert report_main([*map(str, shards), "-o", str(out)]) == 0
    text = out.read_text()
    assert text.count("| RVN (ours) | Oracle |") == 1 and "| Oracle | oracle | val | 2 × 2 | 3 | 4 |" in text
    assert "eval/oracle/episodes.jsonl" in text and "eval/oracle_b/episodes.jsonl" in text


def test_significance_between_rows(runs, tmp_path):
    """Fisher's exact test on SR_1 and the exact two-Poisson-rate test on CPK, from the episode records."""
    from scipy.stats import binomtest, fisher_exact

    from rvn_data.benchmark.significance import Row, cpk_p, sr1_p

    out = tmp_path / "report.md"
    proc = report(str(runs / "eval" / "oracle"), str(runs / "eval" / "random"), "-o", str(out),
                  "--compare", "Oracle=NoMaD-PointGoal")
    assert proc.returncode == 0, proc.stderr
    text = out.read_text()
    rows = []
    for name in ("oracle", "random"):
        m = json.loads((runs / "eval" / name / "metrics.json").read_text())
        recs = read_records(runs / "eval" / name / "episodes.jsonl")
        rows.append((sum(r["first_goal_success"] for r in recs), len(recs), m["collisions"], m["distance_km"]))
    (ka, na, ca, da), (kb, nb, cb, db) = rows
    p_sr = fisher_exact([[ka, na - ka], [kb, nb - kb]]).pvalue
    p_cpk = binomtest(ca, ca + cb, da / (da + db)).pvalue if ca + cb else 1.0
    line = next(ln for ln in text.splitlines() if ln.startswith("| Oracle | NoMaD-PointGoal |"))
    assert f"({ka}/{na})" in line and f"({kb}/{nb})" in line
    assert line.split("|")[5].strip() == f"{p_sr:.2g}" and line.split("|")[8].strip() == f"{p_cpk:.2g}"
    # the tests themselves, on counts where the answer is known
    a, b = Row("a", 30, 200, 10, 1.0), Row("b", 30, 200, 10, 1.0)
    assert sr1_p(a, b) == pytest.approx(1.0) and cpk_p(a, b) == pytest.approx(1.0)
    assert cpk_p(Row("a", 0, 1, 10, 1.0), Row("b", 0, 1, 0, 1.0)) == pytest.approx(2 * 0.5 ** 10)
    assert sr1_p(Row("a", 100, 200, 0, 1.0), Row("b", 10, 200, 0, 1.0)) < 1e-10
    bad = report(str(runs / "eval" / "oracle"), "-o", str(tmp_path / "r.md"), "--compare", "Oracle=PPO")
    assert bad.returncode == 2 and "'PPO'" in bad.stderr and "Traceback" not in bad.stderr
    assert "--compare-present" in bad.stderr and not (tmp_path / "r.md").exists()
    # a partial run's report: pairs whose rows are absent are left out and listed, the others tested as before
    partial = tmp_path / "partial.md"
    proc = report(str(runs / "eval" / "oracle"), str(runs / "eval" / "random"), "-o", str(partial),
                  "--compare", "Oracle=PPO", "--compare", "Oracle=NoMaD-PointGoal", "--compare-present")
    assert proc.returncode == 0, proc.stderr
    text = partial.read_text()
    assert line in text and "Not tested (a row is not among these runs): Oracle = PPO." in text
    assert "| Oracle | PPO |" not in text


def test_bar_plot_legend_key_beside_its_text(tmp_path, monkeypatch):
    """The paper's black tick has a short key of its own in the legend, left of the text, not over it."""
    from types import SimpleNamespace

    import numpy as np
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    from rvn_data.benchmark import plots

    figs = []
    monkeypatch.setattr(plots, "_save", lambda fig, path: figs.append(fig))
    runs = [SimpleNamespace(label="NoMaD-PointGoal", metrics={"SR_1": 0.5}, paper=lambda: (0.75, 3.7, 35.7)),
            SimpleNamespace(label="Oracle", metrics={"SR_1": 0.9}, paper=lambda: None)]
    plots.bar_plot(runs, "SR_1", 0, "SR_1", "SR_1", 3, tmp_path / "sr1.png", top=1.0)
    canvas = FigureCanvasAgg(figs[0])
    canvas.draw()
    legend = figs[0].axes[0].get_legend()
    assert [t.get_text() for t in legend.get_texts()] == ["paper (same method and split)"]
    key = legend.legend_handles[0].get_window_extent(canvas.get_renderer())
    text = legend.get_texts()[0].get_window_extent(canvas.get_renderer())
    assert np.isfinite([key.x0, key.x1]).all() and 0 < key.width and key.x1 <= text.x0


def test_runs_of_different_identity_are_different_rows(runs, tmp_path):
    """Issue 35: a method label shared by two different evaluations (here the random policy with two seeds,
    both called NoMaD-PointGoal) gives two rows, told apart by folder; shards of one identity whose
    shared episodes disagree are refused in one line; the report flags rows on different episode sets."""
    other = tmp_path / "random_seed1"
    rvn_eval(tmp_path, "policy=random", "method=NoMaD-PointGoal", "seed=1", f"out_dir={other}")
    rows = merge_shards(find_runs([runs / "eval" / "random", other]))
    assert [r.method for r in rows] == ["NoMaD-PointGoal [random]", "NoMaD-PointGoal [random_seed1]"]
    out = tmp_path / "r.md"
    assert report_main([str(runs / "eval" / "random"), str(other), "-o", str(out)]) == 0
    text = out.read_text()
    assert "| RVN (ours) | NoMaD-PointGoal [random] |" in text and "| RVN (ours) | NoMaD-PointGoal [random_seed1] |" in text
    # seed 1 drew other episodes: flagged above the table
    assert "val rows on different episode sets" in text.split("| Category |")[0]
    # a copy of a shard with one episode's result changed: same identity, disagreeing records
    forged = tmp_path / "forged"
    shutil.copytree(runs / "eval" / "oracle", forged)
    recs = read_records(forged / "episodes.jsonl")
    recs[0]["collisions"] += 1
    (forged / "episodes.jsonl").write_text("".join(json.dumps(r) + "\n" for r in recs))
    proc = report(str(runs / "eval" / "oracle"), str(forged), "-o", str(tmp_path / "f.md"))
    assert proc.returncode == 2 and "are not shards of one evaluation" in proc.stderr and len(proc.stderr.splitlines()) == 1
    assert not (tmp_path / "f.md").exists()


def test_checkpoint_runs_are_labelled_by_their_folder(tmp_path):
    """Issue 35: rvn-eval policy=checkpoint without method= records the checkpoint folder's name as the
    method (never 'checkpoint' for every model)."""
    from rvn_data.benchmark.cli import _typed_config
    from rvn_data.config import load_config

    cfg = load_config("eval", ["policy=checkpoint", f"policy.checkpoint_path={tmp_path / 'nomad_seed1'}", "out_dir=x"])
    config, _ = _typed_config(cfg)
    assert config.method == "nomad_seed1" and config.policy["checkpoint_path"] == str(tmp_path / "nomad_seed1")
    assert _typed_config(load_config("eval", ["policy=random", "out_dir=x"]))[0].method == "policy"


def test_paired_tests_on_the_same_episodes():
    """McNemar on the discordant episodes and the paired CPK tests, on counts where the answer is known."""
    from rvn_data.benchmark.significance import Row, paired

    def row(label, per):
        succ = sum(s for s, _, _ in per.values())
        return Row(label, succ, len(per), sum(c for _, c, _ in per.values()), sum(k for _, _, k in per.values()), per)

    n = 200
    a = row("a", {f"e{i}": (i < 120, int(i % 10 == 0), 0.05) for i in range(n)})   # 20 collisions over 10 km
    b = row("b", {f"e{i}": (i < 100, int(i % 5 == 0), 0.05) for i in range(n)})    # 40 collisions over 10 km
    res = paired(a, b)
    assert (res["won"], res["lost"]) == (20, 0) and res["mcnemar_p"] == pytest.approx(2 * 0.5 ** 20)
    assert res["cpk_ratio"] == pytest.approx(0.5) and res["cpk_ratio_ci"][0] < 0.5 < res["cpk_ratio_ci"][1] < 1.0
    assert res["cpk_paired_p"] < 0.01 and paired(a, b) == res  # seeded: the same records, the same p
    same = paired(a, row("a2", dict(a.per_episode)))
    assert same["cpk_ratio"] == pytest.approx(1.0) and same["cpk_paired_p"] == 1.0 and same["mcnemar_p"] == 1.0
    assert paired(a, row("c", {f"x{i}": (True, 0, 0.05) for i in range(n)})) is None  # other episodes: not paired


def test_the_cpk_ratio_lies_in_its_interval_with_few_collisions():
    """The interval is of the ratio the table prints (its bootstrap once added 0.5 to each side's collisions: a ratio
    of 0 at [0.05, 0.33]); with no collision in A it is the exact conditional interval of two Poisson rates."""
    from rvn_data.benchmark.significance import Row, paired

    def row(label, collided):
        per = {f"e{i}": (True, int(i < collided), 0.02) for i in range(100)}
        return Row(label, 100, 100, collided, 2.0, per)

    for ca, cb in ((0, 5), (2, 5), (20, 5), (5, 40)):
        res = paired(row("a", ca), row("b", cb))
        lo, hi = res["cpk_ratio_ci"]
        assert res["cpk_ratio"] == pytest.approx(ca / cb) and lo <= res["cpk_ratio"] <= hi, (ca, cb, res)
    lo, hi = paired(row("a", 0), row("b", 5))["cpk_ratio_ci"]
    assert lo == 0.0 and 0.5 < hi < 2.0  # 0 of 5 collisions at equal exposure: the rate ratio up to ~1.09


def test_rows_on_other_episodes_under_the_same_ids_are_not_paired(tmp_path):
    """Runs of one split with another episode seed (or goal distances) name their episodes alike: the report's paired
    tests match an episode by its id and first goal's distance, as the episode-set digest does."""
    from rvn_data.benchmark.report import tests
    from rvn_data.benchmark.runs import Run

    def run(name, shift):
        records = [{"episode_id": f"s#{i}", "scene_id": "s", "episode_index": i, "first_goal_success": i % 2 == 0,
                    "collisions": i % 3 == 0, "path_length": 20.0, "d0": 4.0 + i / 10 + shift} for i in range(30)]
        return Run(tmp_path / name, {"method": name, "split": "val", "collisions": 10, "distance_km": 0.6}, records)

    assert tests([run("a", 0.0), run("b", 0.0)]).splitlines()[-1].endswith("| 0–0, 1 | 1.00 [1.00, 1.00], 1 |")
    assert tests([run("a", 0.0), run("c", 0.5)]).splitlines()[-1].endswith("| – | – |")


def test_pairs_are_pooled_over_training_seeds(tmp_path):
    """Rows of another training seed ("<method> seed<s>", as the recipes label them) beside a compared pair: the report
    also tests the pair pooled over the seeds, every seed's episodes paired with the same seed's."""
    from rvn_data.benchmark.report import tests
    from rvn_data.benchmark.runs import Run

    def run(name, wins, shift=0.0, n=20):  # the first `wins` episodes reach their first goal; one collision each
        records = [{"episode_id": f"s#{i}", "scene_id": "s", "episode_index": i, "first_goal_success": i < wins,
                    "collisions": 1, "path_length": 10.0, "d0": 4.0 + i / 10 + shift} for i in range(n)]
        return Run(tmp_path / name, {"method": name, "split": "val", "collisions": n, "distance_km": n / 100}, records)

    rows = [run("A", 12), run("B", 4), run("A seed1", 10), run("B seed1", 6), run("C", 5)]
    text = tests(rows, [("A", "B"), ("A seed1", "B seed1"), ("A", "C")])
    pooled = [ln for ln in text.splitlines() if "| unlabelled" in ln]
    assert pooled == ["| A | B | unlabelled + seed1 | 40 | 0.550 | 0.250 | 12–0, 0.00049 | 100.0 | 100.0 | "
                      "1.00 [1.00, 1.00], 1 |"], text
    assert "pooled over training seeds" in text and "| A | C | unlabelled" not in text  # C has no seed-1 row
    assert "pooled" not in tests(rows, [("A", "C")])
    # seed 1's rows on other episodes than each other: not paired, so not pooled
    assert "pooled" not in tests([run("A", 12), run("B", 4), run("A seed1", 10), run("B seed1", 6, shift=0.5)], [("A", "B")])
    # a checkpoint's rows compared step by step: seed 1's are "<method> seed1 ckpt<n>" (small_experiment.sh's labels)
    at_step = [run("A ckpt5", 12), run("B ckpt5", 4), run("A seed1 ckpt5", 10), run("B seed1 ckpt5", 6)]
    text = tests(at_step, [("A ckpt5", "B ckpt5"), ("A seed1 ckpt5", "B seed1 ckpt5")])
    assert [ln for ln in text.splitlines() if "| unlabelled" in ln] == [
        "| A ckpt5 | B ckpt5 | unlabelled + seed1 | 40 | 0.550 | 0.250 | 12–0, 0.00049 | 100.0 | 100.0 | "
        "1.00 [1.00, 1.00], 1 |"], text


def test_rows_are_read_over_their_checkpoints(tmp_path):
    """Rows of a run's other checkpoints ("<method> ckpt<env steps>", as jobs/rl_small.sh's EVAL_CHECKPOINTS labels
    them) beside a compared row: the report also tests it read as their mean, per episode the share of checkpoints that
    reached the first goal, by a paired randomisation test on the per-episode differences; pooled over seeds too."""
    from rvn_data.benchmark.report import tests
    from rvn_data.benchmark.runs import Run
    from rvn_data.benchmark.significance import Row, over_checkpoints, paired

    def run(name, wins, n=20, km=10.0):  # the first `wins` episodes reach their first goal; one collision each
        records = [{"episode_id": f"s#{i}", "scene_id": "s", "episode_index": i, "first_goal_success": i < wins,
                    "collisions": 1, "path_length": km, "d0": 4.0 + i / 10} for i in range(n)]
        return Run(tmp_path / name, {"method": name, "split": "val", "collisions": n, "distance_km": n * km / 1e3}, records)

    rows = [run("A", 12), run("A ckpt50", 8, km=30.0), run("B", 4)]
    text = tests(rows, [("A", "B")])
    assert "| A | B | 0.600 (12/20) | 0.200 (4/20) |" in text  # the row itself, as before
    assert "| A | 50, the row's | 0.400, 0.600 | 0.500 | 33, 100 | 50.0 |" in text, text  # 1 / 30 m, 1 / 10 m
    line = next(ln for ln in text.splitlines() if ln.startswith("| A | B | 2 / 1 | 20 |"))
    # shares 1 (episodes 0-7), 0.5 (8-11), 0 against B's 1 on 0-3: +1 on four episodes, +0.5 on four; all eight
    # signs alike, 2 / 256 = 0.0078, is the only draw as far out (10,000 draws: 0.0073)
    assert "| 0.500 | 0.200 | 6–0, 0.0073 | 50.0 | 100.0 | 0.50 [0.50, 0.50], <1e-4 |" in line, line
    assert "read over checkpoints and pooled" not in text
    # with seed 1's rows: the mean rows pooled over the seeds
    seeded = rows + [run("A seed1", 10), run("A seed1 ckpt40", 10), run("B seed1", 10)]
    text = tests(seeded, [("A", "B"), ("A seed1", "B seed1")])
    pooled = text.split("read over checkpoints and pooled over training seeds:")[1]
    assert "| A | B | unlabelled + seed1 | 40 | 0.500 | 0.350 | 6–0, 0.0" in pooled, pooled
    # without such rows, or on other episodes, nothing is read over checkpoints
    assert "checkpoints" not in tests([run("A", 12), run("B", 4)], [("A", "B")])
    assert "checkpoints" not in tests([run("A", 12), run("A ckpt50", 8, n=19), run("B", 4)], [("A", "B")])
    # a mean of rows alike keeps whole shares: McNemar's exact test, as on the row alone
    a = Row("a", 12, 20, 20, 0.2, {i: (i < 12, 1, 0.01) for i in range(20)})
    b = Row("b", 4, 20, 20, 0.2, {i: (i < 4, 1, 0.01) for i in range(20)})
    means, groups = over_checkpoints([a, Row("a ckpt5", 12, 20, 20, 0.2, dict(a.per_episode)), b])
    assert [r.label for r in means] == ["a", "b"] and len(groups["a"]) == 2
    assert paired(means[0], b)["mcnemar_p"] == paired(a, b)["mcnemar_p"] == pytest.approx(2 * 0.5 ** 8)
    # a row with no collisions against a mean row with half of one (one of its two checkpoints collided once): the
    # ratio 0, its interval unbounded (B's collisions rounded down: none to bound it); with one and a half, B's one
    c = Row("c", 1, 2, 0, 0.02, {0: (1, 0, 0.01), 1: (0, 0, 0.01)})
    d = Row("d", 1, 2, 1, 0.02, {0: (1, 1, 0.01), 1: (0, 0, 0.01)})
    means, _ = over_checkpoints([d, Row("d ckpt5", 1, 2, 0, 0.02, {0: (1, 0, 0.01), 1: (0, 0, 0.01)}), c])
    assert paired(c, means[0])["cpk_ratio_ci"] == (0.0, float("inf"))
    three = Row("e", 1, 2, 3, 0.02, {0: (1, 3, 0.01), 1: (0, 0, 0.01)})
    means, _ = over_checkpoints([three, Row("e ckpt5", 1, 2, 0, 0.02, {0: (1, 0, 0.01), 1: (0, 0, 0.01)}), c])
    one = Row("f", 1, 2, 1, 0.02, {0: (1, 1, 0.01), 1: (0, 0, 0.01)})
    assert paired(c, means[0])["cpk_ratio_ci"] == paired(c, one)["cpk_ratio_ci"]


def test_rows_read_over_checkpoints_on_recorded_evaluations():
    """The report on docs/results' records of PPO at 600k and 800k env steps, each with its earlier checkpoint's row,
    both training seeds: read over the two checkpoints, pooled, 800k leads 60-32 (2026-12-06_rl_checkpoints)."""
    from rvn_data.benchmark.report import tests
    from rvn_data.benchmark.runs import load_run

    results = Path(__file__).resolve().parents[1] / "docs" / "results"
    dirs = [f"2026-12-06_ppo_600k/eval/ppo_{k}{s}" for k in ("600k", "800k") for s in ("", "_seed1")]
    dirs += [f"2026-12-06_rl_checkpoints/eval/ppo_{k}{s}_ckpt{at}" for k, at in (("600k", 593920), ("800k", 798720))
             for s in ("", "_seed1")]
    text = tests([load_run(results / d) for d in dirs], [("PPO 800k", "PPO 600k"), ("PPO 800k seed1", "PPO 600k seed1")])
    assert "| PPO 800k seed1 | 798720, the row's | 0.250, 0.335 | 0.292 |" in text, text
    pooled = text.split("read over checkpoints and pooled over training seeds:")[1]
    assert "| PPO 800k | PPO 600k | unlabelled + seed1 | 400 | 0.291 | 0.221 | 60–32, 0.0006 |" in pooled, pooled
    single = text.split("Val, pooled over training seeds")[1]  # the latest checkpoints alone
    assert "| PPO 800k | PPO 600k | unlabelled + seed1 | 400 | 0.312 | 0.225 | 71–36," in single, single
