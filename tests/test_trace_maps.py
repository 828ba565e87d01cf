"""rvn-eval paths=true: each episode's trace (poses, goals, ending) beside its record, a map a scene of where the
episodes went and how they ended, and `python -m rvn_data.benchmark.trace_maps` drawing them again with collision
clips; bad input in one line."""
import gzip
import json
import os
import re
import subprocess
import sys
from pathlib import Path

import cv2
import numpy as np
import pytest
from PIL import Image

from rvn_data.benchmark.trace_maps import load_traces, trace_legend

pytestmark = pytest.mark.slow  # end-to-end runs of the CLIs; the fast tier is -m "not slow"

SMALL = ["policy=goal_follower", "split=val", "episodes.num_scenes=2", "episodes.per_scene=3", "episodes.n_goals=2",
         "camera.width=32", "camera.height=32", "progress=false"]


def rvn_eval(tmp: Path, out: Path, *extra: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-c", "from rvn_data.benchmark.cli import main; main()", *SMALL,
                           f"out_dir={out}", *extra], capture_output=True, text=True, timeout=600,
                          env={**os.environ, "RVN_CACHE_DIR": str(tmp / "cache")})


def trace_maps(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "rvn_data.benchmark.trace_maps", *args], capture_output=True,
                          text=True, timeout=600)


def gif_frames(path: Path) -> list[np.ndarray]:
    im, frames = Image.open(path), []
    for i in range(getattr(im, "n_frames", 1)):
        im.seek(i)
        frames.append(np.array(im.convert("RGB")))
    return frames


@pytest.fixture(scope="module")
def run(tmp_path_factory) -> Path:
    tmp = tmp_path_factory.mktemp("traces")
    proc = rvn_eval(tmp, tmp / "eval", "paths=true", "workers=2")
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert "2 map(s) of the episodes' paths" in proc.stderr
    return tmp / "eval"


def test_a_trace_beside_each_record(run):
    records = [json.loads(line) for line in (run / "episodes.jsonl").read_text().splitlines()]
    traces = load_traces(run)
    assert len(records) == len(traces) == 6
    episodes = {}
    for f in (run.parent / "cache" / "episodes").rglob("*.json.gz"):
        doc = json.loads(gzip.decompress(f.read_bytes()))
        for e in doc["episodes"]:
            episodes[(doc["scene_index"], e["episode_index"])] = e
    by_key = {(r["scene_index"], r["episode_index"]): r for r in records}
    for t, key in zip(traces, sorted(by_key)):
        rec, ep = by_key[key], episodes[key]
        assert t["scene_id"] == rec["scene_id"] and t["termination"] == rec["termination"]
        assert t["spec"] == rec["scene_id"]  # procedural scenes: the spec is the id
        assert len(t["positions"]) == len(t["yaws"]) == len(t["goals_reached"]) == rec["steps"] + 1
        assert np.allclose(t["positions"][0], ep["start_position"], atol=1e-5)
        assert np.allclose(t["goals"], ep["goals"][:2], atol=1e-5)
        moved = np.linalg.norm(np.diff(t["positions"].astype(np.float64), axis=0), axis=1).sum()
        assert abs(moved - rec["path_length"]) < 1e-3 * max(1, rec["steps"])
        assert int(t["goals_reached"][-1]) == rec["goals_reached"]
    assert any(t["termination"] == "collision" for t in traces)


def test_maps_and_clips_drawn_again_from_the_folder(run, tmp_path):
    maps = sorted((run / "maps").glob("*.png"))
    assert [m.name for m in maps] == ["procedural_val_0.png", "procedural_val_1.png"]
    first = {m.name: m.read_bytes() for m in maps}
    traces = load_traces(run)
    for m, scene in zip(maps, ("procedural:val/0", "procedural:val/1")):
        img = cv2.imread(str(m))
        legend = trace_legend(img.shape[1])
        assert np.array_equal(img[-len(legend):], legend)  # the legend strip under the map
        body = img[:-len(legend)]
        assert body.shape[0] > 200 and body.shape[1] > 200
        hits = sum(t["termination"] == "collision" for t in traces if t["scene_id"] == scene)
        assert ((body == (0, 0, 230)).all(-1)).any() == (hits > 0)  # a red cross where an episode collided
        assert ((body == (0, 170, 0)).all(-1)).sum() >= 3  # the start dots
    proc = trace_maps(str(run), "--clips", "2", "--backend", "raycast")
    assert proc.returncode == 0, proc.stderr
    assert "wrote 2 map(s)" in proc.stdout and "2 clip(s)" in proc.stdout
    assert {m.name: m.read_bytes() for m in sorted((run / "maps").glob("*.png"))} == first  # the same pictures
    clips = sorted((run / "clips").glob("*.gif"))
    assert len(clips) == 2 and all(c.name.endswith("-collision.gif") for c in clips)
    collided = [t for t in load_traces(run) if t["termination"] == "collision"][:2]
    for clip, t in zip(clips, collided):
        frames = gif_frames(clip)
        assert len(frames) == min(9, len(t["positions"]))
        last = frames[-1]
        assert last.shape[0] >= 192 and (abs(last[:3, :100].astype(int) - (230, 0, 0)).sum(-1) < 60).mean() > 0.9


def test_the_report_links_the_maps(run, tmp_path):
    from rvn_data.benchmark.report import main as report_main

    assert report_main([str(run), "-o", str(tmp_path / "report.md")]) in (0, None)
    text = (tmp_path / "report.md").read_text()
    assert f"[maps]({os.path.relpath(run / 'maps', tmp_path)}/)" in text


def test_timed_out_episodes_on_the_map_and_in_clips(run, tmp_path):
    out = tmp_path / "short"
    proc = rvn_eval(run.parent, out, "paths=true", "env.t_max=2")  # 2 steps a goal: most episodes time out
    assert proc.returncode == 0, proc.stderr[-3000:]
    timed_out = [t for t in load_traces(out) if t["termination"] == "timeout"]
    assert len(timed_out) >= 2
    img = cv2.imread(str(out / "maps" / f"procedural_val_{timed_out[0]['scene_id'][-1]}.png"))
    body = img[:-len(trace_legend(img.shape[1]))]
    assert ((body == (0, 140, 255)).all(-1)).any()  # an orange ring where an episode timed out
    proc = trace_maps(str(out), "--timeout-clips", "2", "--backend", "raycast", "--format", "mp4")
    assert proc.returncode == 0 and "2 clip(s)" in proc.stdout, proc.stderr
    videos = sorted((out / "clips").glob("*-timeout.mp4"))
    assert len(videos) == 2 and all(cv2.VideoCapture(str(v)).get(cv2.CAP_PROP_FRAME_COUNT) >= 2 for v in videos)
    proc = trace_maps(str(out), "--timeout-clips", "2", "--backend", "raycast")
    assert proc.returncode == 0 and "2 clip(s)" in proc.stdout, proc.stderr
    clips = sorted((out / "clips").glob("*.gif"))
    assert len(clips) == 2 and all(c.name.endswith("-timeout.gif") for c in clips)
    for clip, t in zip(clips, timed_out):
        frames = gif_frames(clip)
        assert len(frames) == min(17, len(t["positions"]))
        assert (abs(frames[-1][:3, :100].astype(int) - (255, 140, 0)).sum(-1) < 60).mean() > 0.9


def test_the_same_run_writes_the_same_traces(run, tmp_path):
    proc = rvn_eval(run.parent, tmp_path / "again", "paths=true")
    assert proc.returncode == 0, proc.stderr[-3000:]
    for f in sorted((run / "paths").glob("*.npz")):
        assert (tmp_path / "again" / "paths" / f.name).read_bytes() == f.read_bytes(), f.name


def test_a_run_started_over_drops_the_traces_and_maps_of_the_one_before(run, tmp_path):
    out = tmp_path / "over"
    assert rvn_eval(run.parent, out, "paths=true").returncode == 0
    (out / "paths" / "00000-0000.npz").replace(out / "paths" / "00009-0009.npz")  # as a run of other episodes left
    assert rvn_eval(run.parent, out, "paths=true").returncode == 0  # resumed: every episode done, a trace too many
    assert not (out / "paths" / "00009-0009.npz").exists() and not (out / "paths" / "00000-0000.npz").exists()
    assert rvn_eval(run.parent, out, "resume=false", "episodes.per_scene=1").returncode == 0  # over, without paths
    assert not (out / "paths").exists() or not any((out / "paths").iterdir())
    assert not (out / "maps").exists()
    theirs = tmp_path / "theirs"  # a folder of the user's own maps/, no run of ours: nothing of it removed
    (theirs / "maps").mkdir(parents=True)
    (theirs / "maps" / "plan.png").write_bytes(b"not ours")
    assert rvn_eval(run.parent, theirs, "resume=false").returncode == 0
    assert (theirs / "maps" / "plan.png").read_bytes() == b"not ours"


def test_bad_input_is_one_line(run, tmp_path):
    plain = tmp_path / "plain"
    assert rvn_eval(run.parent, plain).returncode == 0
    assert not (plain / "paths").exists() and not (plain / "maps").exists()  # paths=false (the default): none
    again = rvn_eval(run.parent, plain, "paths=true")  # not part of the run's identity: the finished run, no traces
    assert again.returncode == 0 and "0 map(s)" in again.stderr and "6 of 6 episodes ran without paths=true" in \
        again.stderr, again.stderr
    for args, said in (([str(plain)], "no episode traces in"), ([str(tmp_path)], "no run.json"),
                       ([str(run), "--clips", "-1"], "--clips -1 must be >= 0")):
        proc = trace_maps(*args)
        assert proc.returncode == 2 and said in proc.stderr and len(proc.stderr.strip().splitlines()) == 1, proc.stderr


def test_benchmark_prints_the_step_map_and_clip_costs(monkeypatch, capsys):
    monkeypatch.syspath_prepend(str(Path(__file__).resolve().parents[1] / "benchmarks"))
    import trace_maps as bench

    bench.main(["--scenes", "1", "--per-scene", "2", "--pairs", "1", "--size", "32"])
    out = capsys.readouterr().out
    assert re.search(r"episode step: [\d.]+ ms plain, [\d.]+ ms recording the trace .* x[\d.]+ the median pair", out)
    assert re.search(r"maps: \d+ ms a scene \(1 scenes, 2 episodes each.*clips: \d+ ms a collision", out), out
