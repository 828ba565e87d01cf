"""``load_policy``: rebuild a policy from an rvn-train checkpoint directory alone.

rvn-eval's ``policy=checkpoint`` (conf/policy/checkpoint.yaml, registered as entry point ``rvn.policies``
``checkpoint``): ``{_target_: rvn_il.policies.load_policy, checkpoint_path: <out_dir>, device: cpu,
selection: argmin}`` — every keyword besides ``checkpoint_path``/``device``/``model`` overrides
a ``model.policy`` setting (lookahead_min_dist, waypoint_index, num_samples, aggregate, stop_radius,
selection, cor_alpha, ensemble, sampler, depth_veto, depth_veto_rule, depth_veto_hfov, escape_after, escape_steps,
escape_clearance, turn_commit), the seed, ``step`` (a kept checkpoint other than the latest, by its optimiser
step: ``<member>/ckpt_<step>``, e.g. to evaluate a run over its last few), ``threads`` (torch intra-op threads of a decision
on CPU, default 1, null: torch's setting; see :mod:`.policy`) or an agent setting (r_robot, d_step, theta_step_deg).

``ensemble``: more rvn-train out_dirs of the same model (ViNT- or NoMaD-PointGoal) whose samples join
the first checkpoint's in ``aggregate=vote`` (every member draws ``num_samples``; ties go to the
earliest sample, the first checkpoint's first). Control and agent settings are the first checkpoint's.

``compile``: true runs each network's frame encoder and NoMaD's whole sampling (condition, FiLM biases, every
denoising step) through torch.compile (on CUDA as CUDA graphs; :mod:`rvn_il.models.compiled`): same noise, same
actions up to float rounding, a faster decision after a first one that compiles (NoMaD full: about 3.5 minutes on
a CPU core; kernels cached under the cache root).

``sampler``: NoMaD's reverse process, ``ddpm`` (default, the paper's) or ``ddim`` (η = 0), for every
network of the policy (:mod:`rvn_il.models.nomad`); ViNT has none, so anything but ddpm is an error.

``depth_veto``: metres (null: off); a MOVE_FORWARD whose clearance ahead, predicted by the
checkpoint's auxiliary depth head, is below it becomes a turn (:mod:`.depth_veto`; a departure).
``depth_veto_rule``: band (the central half of the columns) or swept (the rectangle the step sweeps,
with the camera's hfov: ``depth_veto_hfov`` degrees, null: the ``hfov_deg`` the checkpoint recorded).
``escape_after``: turns in place in a row after which the policy turns to the most open heading it saw
near the goal's bearing and drives ``escape_steps`` (4) steps there, headings with ``escape_clearance``
(1.0 m) free first (null: off; :mod:`.escape`; a departure).
``turn_commit``: true makes a turn against the previous step's turn repeat that turn instead, so the robot sweeps
round instead of dithering left-right (default false; :mod:`.turn_commit`; a departure).
"""
from __future__ import annotations

from pathlib import Path
from typing import Any

import torch

from rvn_data.conventions import AgentConfig
from rvn_data.embodiment import AGENT_KEYS as EMBODIMENT_AGENT_KEYS

from ..data.images import crop_setting
from ..models import build_model, resolve_size
from ..models.checkpoint import (checked_step, checkpoint_of, load_state_dict_checked, members_of, read_config,
                                 read_stats, read_weights)
from ..models.compiled import check_compile, compile_for_inference
from ..models.nomad import check_sampler
from .control import ControlConfig
from .depth_veto import Floor, check_depth_veto
from .escape import Escape
from .turn_commit import TurnCommit
from .policy import Member, NoMaDNegPolicy, PointGoalPolicy

POLICY_KEYS = {"lookahead_min_dist", "waypoint_index", "num_samples", "aggregate", "stop_radius", "selection", "cor_alpha",
               "seed", "threads", "ensemble", "sampler", "compile", "depth_veto", "depth_veto_rule", "depth_veto_hfov",
               "escape_after", "escape_steps", "escape_clearance", "turn_commit", "step"}
AGENT_KEYS = set(EMBODIMENT_AGENT_KEYS)  # policy.* settings that change the robot's control


def resolve_device(device: str | torch.device, setting: str = "device") -> torch.device:
    """``auto`` (CUDA when there is one), ``cpu``, ``cuda`` or ``cuda:N``; a ValueError naming
    ``setting`` when the device does not exist here."""
    if str(device) == "auto":
        return torch.device("cuda" if torch.cuda.is_available() else "cpu")
    try:
        dev = torch.device(device)
    except (RuntimeError, TypeError):
        raise ValueError(f"{setting}={device!r} is not a device; choose auto, cpu, cuda or cuda:N") from None
    if dev.type == "cuda":
        if not torch.cuda.is_available():
            build = "has no CUDA" if torch.version.cuda is None else "finds no GPU"
            raise ValueError(f"{setting}={device}: this torch ({torch.__version__}) {build}; use {setting}=cpu or auto, "
                             "or install a CUDA build of torch on a GPU machine")
        if dev.index is not None and dev.index >= torch.cuda.device_count():
            raise ValueError(f"{setting}={device}: only {torch.cuda.device_count()} GPU(s) here")
    return dev


def load_member(out_dir: Path, member: str, model_cfg: dict, device: torch.device, step: int | None = None) -> Member:
    """One trained network (EMA weights when present) and its statistics, in eval mode, from its latest checkpoint
    or the one after ``step`` steps; its crop is the checkpoint's ``crop`` (older stats: ``crop_to_aspect``, true →
    aspect, false → none)."""
    ckpt = checkpoint_of(out_dir / member, step)
    if ckpt is None:
        raise ValueError(f"no checkpoint for {member!r} in {out_dir}: rvn-train has not saved one yet")
    model = build_model(model_cfg)
    load_state_dict_checked(model, read_weights(ckpt, model_cfg["name"]), ckpt)
    stats = read_stats(ckpt)
    crop = crop_setting(stats, setting=f"crop in {ckpt / 'stats.json'}")
    model = model.eval().to(device)
    if device.type == "cuda":  # cuDNN runs NHWC convolutions faster; on a CPU one frame is faster in NCHW
        model.use_channels_last()
    return Member(model, float(stats["metric_waypoint_spacing"]), crop, stats.get("hfov_deg"), training_data(stats))


LOADERS_GROUP = "rvn.checkpoint_loaders"  # package entry points: checkpoint kind -> its policy loader


def checkpoint_kind(out_dir: Path) -> str | None:
    """The ``kind`` another trainer records in its out_dir's config.yaml (rvn-rl: ``rl``); None for
    rvn-train's checkpoints, which this module loads."""
    import yaml

    try:
        cfg = yaml.safe_load((out_dir / "config.yaml").read_text())
    except (OSError, yaml.YAMLError):
        return None
    kind = cfg.get("kind") if isinstance(cfg, dict) else None
    return None if kind is None else str(kind)


def kind_loader(kind: str, out_dir: Path):
    """The policy loader an installed package registers for checkpoints of ``kind`` (entry point group
    ``rvn.checkpoint_loaders`` in its pyproject.toml; rvn-rl's: ``rl = "rvn_rl.policy:load_rl_policy"``)."""
    from importlib.metadata import entry_points

    found = {ep.name: ep for ep in entry_points(group=LOADERS_GROUP)}
    if kind not in found:
        raise ValueError(f"policy.checkpoint_path={out_dir} holds a checkpoint of kind {kind!r} and no installed package "
                         f"loads that kind (entry points {LOADERS_GROUP}: {', '.join(sorted(found)) or 'none'}); "
                         "install the package that trained it, e.g. pip install -e . in RVN's checkout")
    return found[kind].load()


def load_policy(checkpoint_path: str | Path, device: str | torch.device = "cpu", model: str | None = None,
                **overrides: Any) -> PointGoalPolicy:
    """Policy with ``reset()``/``act(obs)`` from an rvn-train ``out_dir``. ``model`` (optional)
    asserts which model the checkpoint must hold."""
    out_dir = Path(checkpoint_path).expanduser()
    if not out_dir.exists():
        raise ValueError(f"policy.checkpoint_path={checkpoint_path} does not exist; pass the out_dir of an "
                         "rvn-train or rvn-rl run")
    kind = checkpoint_kind(out_dir)
    if kind is not None:  # another trainer's out_dir (rvn-rl): the loader its package registers
        return kind_loader(kind, out_dir)(out_dir, device, model, **overrides)
    cfg = read_config(out_dir)
    model_cfg = checked_model_config(cfg, out_dir, model, "checkpoint")
    name = model_cfg["name"]
    unknown = set(overrides) - POLICY_KEYS - AGENT_KEYS
    if unknown:
        import difflib

        key = sorted(unknown)[0]
        close = difflib.get_close_matches(key, sorted(POLICY_KEYS | AGENT_KEYS), n=2, cutoff=0.6)
        raise ValueError(f"policy.{key} is not a policy setting" + (f"; nearest: {', '.join(close)}" if close else "")
                         + f" (valid: {', '.join(sorted(POLICY_KEYS | AGENT_KEYS))})")
    pol = {**(model_cfg.get("policy") or {}), "seed": cfg.get("seed", 0)}
    pol.update({k: v for k, v in overrides.items() if k in POLICY_KEYS})
    agent = AgentConfig(**{**(cfg.get("agent") or {}), **{k: v for k, v in overrides.items() if k in AGENT_KEYS}})
    control = ControlConfig.from_agent(agent, pol.get("stop_radius"), pol.get("lookahead_min_dist"), pol.get("waypoint_index"))
    dev = resolve_device(device, "policy.device")
    compiled = check_compile(pol.get("compile", False), "policy.compile")
    step = policy_step(pol.get("step"), pol.get("ensemble"))
    members = [load_member(out_dir, m, model_cfg, dev, step) for m in members_of(name)]
    hfov = pol.get("depth_veto_hfov")
    veto = check_depth_veto(pol.get("depth_veto"), members[0].model.depth_head is not None, pol.get("depth_veto_rule", "band"),
                            members[0].hfov_deg if hfov is None else hfov, agent.r_robot, agent.d_step)
    escape = None
    if pol.get("escape_after") is not None:  # rvn_il/policies/escape.py
        escape = Escape(pol["escape_after"], agent.theta_step, pol.get("escape_steps", 4), pol.get("escape_clearance", 1.0))
    commit = pol.get("turn_commit", False)
    if not isinstance(commit, bool):
        raise ValueError(f"policy.turn_commit={commit!r}: give true or false")
    camera = (trained_embodiment(cfg, members[0]) or {}).get("camera")  # what the depth head learned to see
    common = dict(num_samples=int(pol.get("num_samples", 8)), seed=int(pol["seed"]), device=dev,
                  threads=pol.get("threads", 1), depth_veto=veto, escape=escape, floor=Floor.of(camera) if camera else None,
                  turn_commit=TurnCommit() if commit else None)
    extra = ensemble_dirs(pol.get("ensemble"))
    if name == "nomad_neg":
        if extra:
            raise ValueError("policy.ensemble: NoMaD-Neg already pairs two networks (expert, negative); ensembles "
                             "are for ViNT- and NoMaD-PointGoal")
        if pol.get("aggregate", "first") != "first":
            raise ValueError(f"policy aggregate={pol['aggregate']!r}: NoMaD-Neg chooses its sample by CoR (policy.selection)")
        set_sampler(members, pol.get("sampler"), name)
        compile_members(members, compiled, dev)
        return with_training_record(NoMaDNegPolicy(members, control, selection=pol.get("selection", "argmax"),
                                                   cor_alpha=float(pol.get("cor_alpha", 1.0)), **common), cfg, members)
    aggregate = str(pol.get("aggregate", "first"))
    if extra and aggregate != "vote":
        raise ValueError(f"policy.ensemble needs policy.aggregate=vote (got {aggregate!r}): the members' samples are pooled "
                         "into one vote")
    members += [load_ensemble_member(d, name, dev) for d in extra]
    set_sampler(members, pol.get("sampler"), name)
    compile_members(members, compiled, dev)
    return with_training_record(PointGoalPolicy(members, control, aggregate=aggregate, **common), cfg, members)


def policy_step(step: Any, ensemble: Any) -> int | None:
    """``policy.step`` as an int (None: the latest checkpoint); a ValueError for anything but a step count, or with
    ``policy.ensemble``, whose runs keep checkpoints at steps of their own."""
    if checked_step(step, "policy.step", "<member>") is None:
        return None
    if ensemble_dirs(ensemble):
        raise ValueError(f"policy.step={step} with policy.ensemble: the ensemble's runs keep checkpoints at steps of "
                         "their own; evaluate an ensemble at its runs' latest checkpoints (leave policy.step unset)")
    return step


def with_training_record(policy, cfg: dict, members: list[Member]):
    """``policy`` with what rvn-eval checks against what it trained on: ``embodiment`` (`trained_embodiment`, the
    first member's) and ``training_data``, the dataset folders of all its members (an ensemble's too)."""
    policy.embodiment = trained_embodiment(cfg, members[0])
    policy.training_data = list(dict.fromkeys(r for m in members for r in m.datasets))
    return policy


def training_data(stats: dict) -> tuple[str, ...]:
    """The dataset folders a network trained on, as its checkpoint's stats.json records them (each dataset's ``root``
    of a mixture, else ``dataset``): rvn-eval names evaluated scenes found in them
    (`rvn_data.benchmark.trained_scenes`)."""
    mixture = [d["root"] for d in stats.get("datasets") or [] if isinstance(d, dict) and d.get("root")]
    return tuple(mixture or ([str(stats["dataset"])] if stats.get("dataset") else []))


def trained_embodiment(cfg: dict, member: Member) -> dict | None:
    """The embodiment record a checkpoint's config.yaml holds (rvn-train writes its data's); for a checkpoint
    written before it did, the camera hfov its data recorded (None: nothing known)."""
    record = cfg.get("embodiment")
    if isinstance(record, dict):
        return {k: v for k, v in record.items() if k != "overrides"}
    return {"camera": {"hfov_deg": member.hfov_deg}} if member.hfov_deg is not None else None


def checked_model_config(cfg: dict, out_dir: Path, model: str | None, what: str) -> dict:
    """The resolved model config of an rvn-train run's ``cfg``; a ValueError naming ``what`` and ``out_dir``
    when ``model`` (None: any) is not the model it holds."""
    model_cfg = resolve_size(cfg["model"])
    if model is not None and model_cfg["name"] != model:
        raise ValueError(f"{what} {out_dir} holds a {model_cfg['name']!r} model, not {model!r}")
    return model_cfg


def set_sampler(members: list[Member], sampler: Any, name: str) -> None:
    """``policy.sampler`` (None: ddpm) on every member's NoMaD network; a ValueError for ViNT, which
    does not sample by diffusion, or for an unknown sampler."""
    sampler = "ddpm" if sampler is None else sampler
    if name == "vint_pointgoal":
        if sampler != "ddpm":
            raise ValueError(f"policy.sampler={sampler!r}: ViNT-PointGoal predicts its waypoints directly; the "
                             "sampler applies to NoMaD-PointGoal and NoMaD-Neg")
        return
    sampler = check_sampler(sampler)
    for m in members:
        m.model.sampler = sampler


def compile_members(members: list[Member], compiled: bool, device: torch.device) -> None:
    """``policy.compile``: every member's network compiled for decisions (:mod:`rvn_il.models.compiled`)."""
    if compiled:
        for m in members:
            compile_for_inference(m.model, device)


def ensemble_dirs(value: Any) -> list[Path]:
    """``policy.ensemble`` as a list of paths: null/empty → [], one path or a list of them."""
    if value is None or value == "":
        return []
    items = [value] if isinstance(value, (str, Path)) else list(value)
    return [Path(str(v)).expanduser() for v in items]


def load_ensemble_member(out_dir: Path, name: str, device: torch.device) -> Member:
    """The network of another rvn-train out_dir of model ``name``, as one more voting member."""
    if not out_dir.is_dir():
        raise ValueError(f"policy.ensemble: {out_dir} does not exist; pass rvn-train out_dirs of {name!r} runs")
    if checkpoint_kind(out_dir) is not None:
        raise ValueError(f"policy.ensemble: {out_dir} is not an rvn-train run of {name!r} (its config records another "
                         "trainer's kind)")
    model_cfg = checked_model_config(read_config(out_dir), out_dir, name, "policy.ensemble: checkpoint")
    return load_member(out_dir, members_of(name)[0], model_cfg, device)
