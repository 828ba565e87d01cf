"""The embodiment record: the robot and camera a dataset was made with, carried from rvn-gen through
rvn-train into the checkpoint and compared by rvn-eval with the environment it runs in.

    {"agent":  {"r_robot": 0.18, "h_robot": 1.0, "d_step": 0.25, "theta_step_deg": 30.0},
     "camera": {"width": 64, "height": 64, "hfov_deg": 90.0, "h_camera": 0.6, "pitch_deg": 0.0, "forward_offset": 0.0,
                "fx": 32.0, "fy": 32.0, "cx": 32.0, "cy": 32.0},
     "expert": {"margin": 0.28, "clearance_pref": 0.5, "clearance_weight": 4.0}}

rvn-gen records its settings in every trajectory's ``rvn_meta.json`` and in ``manifest.json``
(`dataset_embodiment` reads them back); rvn-train writes the record of its data into the
checkpoint's ``config.yaml`` (``embodiment``), with the agent it trained for (`resolve_agent`: the
data's, unless ``agent.*`` is set on the command line, which is announced and recorded under
``embodiment.overrides``); rvn-eval compares the policy's record with its own agent and camera before
any episode (`mismatches`): a difference in `COMPARED` is a one-line error naming both values,
or, with ``embodiment_mismatch=allow``, an announced difference recorded in run.json and metrics.json.
The ``expert`` part is recorded, not compared (the expert is not the environment).
Datasets not written by rvn-gen (other GNM data) have no record: nothing is compared for them.
"""
from __future__ import annotations

import math
from dataclasses import asdict, fields, is_dataclass
from pathlib import Path
from typing import Any, Mapping

from rvn_data.conventions import AgentConfig

# what the environment must match: the robot's motion and body, what the camera sees (fx, fy, cx, cy: the
# intrinsics in pixels as the camera resolves them, given or from hfov_deg; records from before 2026-12-05 lack them
# and forward_offset, which are then not compared)
COMPARED = {"agent": ("r_robot", "h_robot", "d_step", "theta_step_deg"),
            "camera": ("width", "height", "hfov_deg", "h_camera", "pitch_deg", "forward_offset", "fx", "fy", "cx", "cy")}
FRAMING = {"camera.width", "camera.height", "camera.hfov_deg"}
INTRINSICS = {"camera.fx", "camera.fy", "camera.cx", "camera.cy"}
EXPERT_KEYS = ("margin", "clearance_pref", "clearance_weight")
AGENT_KEYS = tuple(f.name for f in fields(AgentConfig))
MISMATCH_CHOICES = ("error", "allow")


def check_robot_settings(agent: Any, camera: Any, navmesh: Any = None) -> None:
    """`check_camera_on_robot`, and `check_navmesh_for_robot` for a navmesh to build (``navmesh.source`` build or
    auto; a navmesh file is the simulator's to check, scene by scene): rvn-gen's, RVNEnv's and rvn-rl's validation."""
    check_camera_on_robot(agent, camera)
    if navmesh is not None and _plain(navmesh).get("source", "build") != "file":
        check_navmesh_for_robot(agent, navmesh)


def check_camera_on_robot(agent: Any, camera: Any) -> None:
    """ValueError naming the settings when the camera is not on the robot: below the floor, above the robot's top
    (``h_camera`` > ``h_robot``) or outside its footprint (``|forward_offset|`` > ``r_robot``). The robot's cylinder is
    what collides, so a camera outside it sees through, or from inside, what the robot passes under or beside: rvn-gen
    wrote an apartment's ceiling from above as "ok" frames with camera.h_camera=3.0."""
    a, c = _plain(agent), _plain(camera)
    h, top, ahead, r = c["h_camera"], a["h_robot"], c.get("forward_offset", 0.0), a["r_robot"]
    if not 0 < h <= top:
        where = "at or below the floor" if h <= 0 else f"above the robot's top (agent.h_robot={top:g} m)"
        raise ValueError(f"camera.h_camera={h:g} m puts the camera {where}: the camera is on the robot, whose "
                         f"cylinder is what collides; set camera.h_camera in (0, {top:g}], or agent.h_robot to the "
                         "height of the robot with its camera")
    if abs(ahead) > r:
        raise ValueError(f"camera.forward_offset={ahead:g} m puts the camera outside the robot (agent.r_robot={r:g} "
                         f"m), where it would enter walls the robot's cylinder stops at; set it within +-{r:g}, or "
                         "agent.r_robot to the robot's radius with its camera")


def check_navmesh_for_robot(agent: Any, navmesh: Any) -> None:
    """ValueError naming the settings when the navmesh to build is not the robot's: another radius (the simulator
    refused it only at each scene), or less headroom than the robot's height (rvn-gen wrote "ok" trajectories with
    navmesh.agent_height=0.3 for a 1 m robot, which may pass under a table). conf/navmesh/default.yaml sets both from
    ``agent``."""
    a, n = _plain(agent), _plain(navmesh)
    if abs(n["agent_radius"] - a["r_robot"]) > 1e-6:
        raise ValueError(f"navmesh.agent_radius={n['agent_radius']:g} differs from agent.r_robot={a['r_robot']:g}: the "
                         "navmesh holds the poses a robot of its radius can take; leave navmesh.agent_radius to follow "
                         "agent.r_robot (conf/navmesh/default.yaml)")
    if n["agent_height"] < a["h_robot"] - 1e-6:
        raise ValueError(f"navmesh.agent_height={n['agent_height']:g} is below agent.h_robot={a['h_robot']:g}: the "
                         "robot would drive under what is lower than itself; leave navmesh.agent_height to follow "
                         "agent.h_robot (conf/navmesh/default.yaml), or raise it")


def _plain(obj: Any) -> dict:
    return asdict(obj) if is_dataclass(obj) else dict(obj or {})


def embodiment_of(agent: Any, camera: Any, expert: Mapping | None = None) -> dict:
    """The record of an agent and a camera (dataclasses or mappings), and the expert's settings if given."""
    a, c = _plain(agent), _plain(camera)
    if "width" in c and "height" in c:  # a camera's settings: its intrinsics as it resolves them
        from rvn_data.render.camera import CameraConfig

        cam = CameraConfig.from_dict({f.name: c[f.name] for f in fields(CameraConfig) if f.name in c})
        (fx, fy), (cx, cy) = cam.focal, cam.principal
        c = {**c, "fx": fx, "fy": fy, "cx": cx, "cy": cy, "forward_offset": cam.forward_offset}
    out = {"agent": {k: a[k] for k in COMPARED["agent"] if k in a},
           "camera": {k: c[k] for k in COMPARED["camera"] if k in c}}
    if expert:
        out["expert"] = {k: expert[k] for k in EXPERT_KEYS if k in expert}
    return out


def dataset_embodiment(root: str | Path, trajectory: str) -> dict | None:
    """The record of an rvn-gen dataset, from the settings in ``<root>/<trajectory>/rvn_meta.json``;
    None for GNM data that rvn-gen did not write (no sidecar, or one without agent and camera)."""
    from rvn_data.dataset.reader import read_meta

    try:
        settings = read_meta(Path(root).expanduser() / trajectory)["settings"]
        return embodiment_of(settings["agent"], settings["camera"], settings)
    except (ValueError, KeyError, TypeError):
        return None


def _same(a: Any, b: Any) -> bool:
    if isinstance(a, (int, float)) and isinstance(b, (int, float)) and not isinstance(a, bool):
        return math.isclose(float(a), float(b), rel_tol=1e-9, abs_tol=1e-9)
    return a == b


def mismatches(trained: Mapping | None, here: Mapping) -> list[dict]:
    """``[{"setting": "camera.hfov_deg", "trained": 90.0, "here": 120.0}, ...]``: the `COMPARED`
    settings both records hold and that differ (none when ``trained`` is None); the intrinsics only where the image
    size and hfov_deg agree (else they differ as a consequence, and the size or hfov is the setting to give)."""
    out = []
    for part, keys in COMPARED.items():
        t, h = dict((trained or {}).get(part) or {}), dict(here.get(part) or {})
        for k in keys:
            if k in t and k in h and not _same(t[k], h[k]):
                out.append({"setting": f"{part}.{k}", "trained": t[k], "here": h[k]})
    if {d["setting"] for d in out} & FRAMING:  # the intrinsics follow: the settings to give are these
        out = [d for d in out if d["setting"] not in INTRINSICS]
    return out


def _fmt(value: Any) -> str:
    return f"{value:g}" if isinstance(value, float) else str(value)


def describe(diffs: list[dict]) -> str:
    return ", ".join(f"{d['setting']}={_fmt(d['here'])} (trained: {_fmt(d['trained'])})" for d in diffs)


def check_embodiment(trained: Mapping | None, here: Mapping, what: str, mode: str = "error") -> list[dict]:
    """Compare a policy's record with the environment's; ValueError (one line) on a difference
    unless ``mode`` is ``allow``; returns the differences."""
    if mode not in MISMATCH_CHOICES:
        raise ValueError(f"embodiment_mismatch={mode!r}; choose one of {', '.join(MISMATCH_CHOICES)}")
    diffs = mismatches(trained, here)
    if diffs and mode == "error":
        fix = " ".join(f"{d['setting']}={_fmt(d['trained'])}" for d in diffs)
        raise ValueError(f"{what} was trained for another robot or camera: {describe(diffs)}; run with {fix}, "
                         "or set embodiment_mismatch=allow to evaluate it anyway (recorded in run.json and metrics.json)")
    return diffs


def resolve_agent(given: Mapping, data: Mapping | None) -> tuple[dict, list[dict]]:
    """rvn-train's agent: ``given`` holds the ``agent.*`` settings of the command line (None: unset);
    unset ones come from the data's record, else `AgentConfig`'s defaults. Returns the complete agent
    and the settings given that differ from the data's (``[{"setting", "data", "given"}]``)."""
    unknown = sorted(set(given) - set(AGENT_KEYS))
    if unknown:
        raise ValueError(f"agent.{unknown[0]} is not an agent setting; choose among {', '.join(AGENT_KEYS)}")
    recorded = dict((data or {}).get("agent") or {})
    agent = asdict(AgentConfig())
    agent.update({k: v for k, v in recorded.items() if k in agent})
    overrides = []
    for k, v in given.items():
        if v is None:
            continue
        if k in recorded and not _same(recorded[k], v):
            overrides.append({"setting": f"agent.{k}", "data": recorded[k], "given": v})
        agent[k] = v
    AgentConfig(**agent)  # validates the values
    return agent, overrides
