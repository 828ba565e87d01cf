"""The machine, the goals and the table of benchmarks/node.py: what the node is (`machine`), how
busy its GPU was while a row ran (`GpuBusy`), issue 32's goals and the published baselines, and the
table as text (markdown) and JSON, written atomically."""
from __future__ import annotations

import json
import os
import threading
import time
from datetime import datetime, timezone
from pathlib import Path

from node_cpu import describe as describe_cpu

# issue 32's goals on a GPU node: (">=" or "<=", value); compared only where CUDA exists
GOALS = {"render_gl": (">=", 6000.0), "gen": (">=", 3000.0), "train_nomad_pointgoal": (">=", 4000.0),
         "train_vint_pointgoal": (">=", 6000.0), "decision_gpu": ("<=", 10.0), "decision_cpu": ("<=", 40.0),
         "rl": (">=", 3000.0)}
HABITAT = {1: "habitat-sim (Titan Xp, published) RGB-D 256²: 1,042 frames/s one process",
           5: "habitat-sim (Titan Xp, published) RGB-D 256²: 1,774 frames/s with five processes"}


def cpu_count() -> int:
    """CPUs this process may run on (the affinity mask where the OS has one)."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:
        return os.cpu_count() or 1


def machine() -> dict:
    """Device (GPU name or "CPU only"), CPU count, torch and CUDA versions, the code's provenance."""
    import torch

    from rvn_data.provenance import provenance

    cuda = torch.cuda.is_available()
    prov = provenance()
    return {"device": torch.cuda.get_device_name(0) if cuda else "CPU only", "cuda": cuda,
            "gpus": torch.cuda.device_count() if cuda else 0, "cpu_count": cpu_count(), "torch": torch.__version__,
            "cuda_version": torch.version.cuda, "commit": prov["commit"], "provenance": prov,
            "date": datetime.now(timezone.utc).isoformat(timespec="seconds")}


def _utilization_reader():
    """A function returning GPU 0's utilization in %, or None where neither torch nor pynvml can read it."""
    import torch

    if not torch.cuda.is_available():
        return None
    try:
        torch.cuda.utilization(0)
        return lambda: float(torch.cuda.utilization(0))
    except Exception:  # torch reads it through pynvml / amdsmi: missing module, no NVML
        pass
    try:
        import pynvml

        pynvml.nvmlInit()
        handle = pynvml.nvmlDeviceGetHandleByIndex(0)
        return lambda: float(pynvml.nvmlDeviceGetUtilizationRates(handle).gpu)
    except Exception:
        return None


def _mean_share(percents: list[float]) -> float | None:
    """The mean of utilization samples (%) as a share in [0, 1]; None without samples."""
    return sum(percents) / len(percents) / 100.0 if percents else None


class GpuBusy:
    """Samples GPU 0's utilization (share of time a kernel ran) every ``interval`` s in a thread while
    the block runs; ``share`` is the mean in [0, 1], or None ("n/a": no GPU, or no NVML to read it), and
    `share_in` the mean over the samples of a time window (a row's timed steps, without its set-up and warm-up)."""

    def __init__(self, interval: float = 0.2):
        self.interval, self.samples, self.share = interval, [], None  # samples: (time.perf_counter(), percent)
        self._read, self._stop = _utilization_reader(), threading.Event()

    def _run(self) -> None:
        while not self._stop.wait(self.interval):
            try:
                self.samples.append((time.perf_counter(), self._read()))
            except Exception:
                return

    def share_in(self, window: list | tuple | None) -> float | None:
        """Mean utilization in [0, 1] of the samples taken in ``window`` ([start, end], perf_counter seconds, as
        `train.steady_train_rate` and `decision.decision_ms` fill it); ``share`` when there is no window or no sample
        in it (a window shorter than the sampling interval)."""
        inside = [v for t, v in self.samples if window and window[0] <= t <= window[1]]
        return _mean_share(inside) if inside else self.share

    def __enter__(self) -> "GpuBusy":
        if self._read is not None:
            self._thread = threading.Thread(target=self._run, daemon=True)
            self._thread.start()
        return self

    def __exit__(self, *exc) -> None:
        if self._read is not None:
            self._stop.set()
            self._thread.join()
            self.share = _mean_share([v for _, v in self.samples])


def compare(row: dict, cuda: bool) -> None:
    """Adds the goal and measured/goal ratio to ``row`` (on a GPU node; elsewhere the goal is kept, not compared)."""
    goal = GOALS.get(row.get("goal_key"))
    row["goal"] = {"op": goal[0], "value": goal[1]} if goal else None
    row["ratio"] = row["met"] = None
    if goal and cuda and row.get("value"):
        row["ratio"] = row["value"] / goal[1]
        row["met"] = row["value"] >= goal[1] if goal[0] == ">=" else row["value"] <= goal[1]


def _num(v: float) -> str:
    return f"{v:,.0f}" if v >= 100 else f"{v:.1f}" if v >= 10 else f"{v:.2f}"


def markdown(info: dict, rows: list[dict], plan: dict) -> str:
    """The table with a header naming the machine and the code."""
    prov = info["provenance"]
    commit = (prov["commit"] or "unknown")[:10] + (" (uncommitted changes)" if prov["dirty"] else "")
    lines = [f"# Node benchmark (issue 32): {info['device']}", "",
             f"device {info['device']} ({info['gpus']} GPU(s), CUDA {info['cuda_version'] or '-'}) | "
             f"{info['cpu_count']} CPUs | torch {info['torch']} | commit {commit} | {info['date']}",
             f"mode: {'quick' if plan['quick'] else 'normal'}, {plan['seconds']:g} s measured per figure after "
             "warm-up (steady state); GPU busy = mean utilization of GPU 0 during the timed steps (training, decision rows), "
             "else while the row ran",
             *([] if info["cuda"] else ["goals of issue 32 are a GPU node's: not compared on a machine without CUDA"]),
             *([describe_cpu(info["cpu"], info["cpu_count"])] if info.get("cpu") else []),
             *([f"--warm (the compiled rows' cold compiles side by side first): {'; '.join(plan['warm'])}"]
               if plan.get("warm") else []),
             *([plan["numba"]] if plan.get("numba") else []),
             "",
             "| # | row | measured | goal (issue 32) | measured/goal | GPU busy | settings, baseline |",
             "|---|-----|---------:|-----------------|--------------:|---------:|--------------------|"]
    for r in rows:
        goal = f"{r['goal']['op']} {_num(r['goal']['value'])} {r['unit']}" if r["goal"] else "-"
        if r["skipped"] or r["error"]:
            measured = f"skipped: {r['skipped']}" if r["skipped"] else f"failed: {r['error']}"
            lines.append(f"| {r['group']} | {r['label']} | {measured} | {goal} | - | - | {r['settings']} |")
            continue
        ratio = "-" if r["ratio"] is None else f"{r['ratio']:.2f} ({'met' if r['met'] else 'not met'})"
        busy = "n/a" if r["gpu_busy"] is None else f"{100 * r['gpu_busy']:.0f}%"
        extra = "; ".join(x for x in (r["settings"], r["baseline"]) if x)
        lines.append(f"| {r['group']} | {r['label']} | {_num(r['value'])} {r['unit']} | {goal} | {ratio} | {busy} | "
                     f"{extra} |")
    profiled = [profile_name(r) for r in rows if r.get("profile")]
    if profiled:
        lines += ["", f"Operator profiles (torch.profiler, a few steps after the timing): {', '.join(profiled)}"]
    return "\n".join(lines) + "\n"


def _atomic_write(path: Path, text: str) -> None:
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    tmp.write_text(text)
    os.replace(tmp, path)


def write(out: Path, info: dict, rows: list[dict], plan: dict, text: str) -> list[Path]:
    """node.md, node.json and a profile_<row>.txt per profiled row (node.py --profile) in ``out``, each written to
    a temporary file, then renamed; node.json names the profile files in place of their text."""
    out.mkdir(parents=True, exist_ok=True)
    paths = []
    for r in rows:
        if r.get("profile"):
            paths.append(out / profile_name(r))
            _atomic_write(paths[-1], f"{r['label']}: {r['settings']}\n\n{r['profile']}")
    listed = [{**r, "profile": profile_name(r) if r.get("profile") else None} for r in rows]
    doc = {**info, "quick": plan["quick"], "seconds_per_row": plan["seconds"], "plan": plan, "rows": listed}
    _atomic_write(out / "node.md", text)
    _atomic_write(out / "node.json", json.dumps(doc, indent=1, default=str) + "\n")
    return [out / "node.md", out / "node.json", *paths]


def profile_name(row: dict) -> str:
    return f"profile_{row['key']}.txt"
