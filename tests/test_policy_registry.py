"""Issue 33 item 3: rvn-eval builds a policy through the package entry points (group rvn.policies), not by
importing a config's dotted path for its side effects. Every conf/policy file's ``_target_`` is registered under
the file's name (its value names the same object, so finished runs' run.json stay as they are); a ``_target_``
that cannot be imported is one line naming the registered policies; one no package registers (a policy of one's
own on PYTHONPATH) still runs, with a note; a stale install (metadata without our policies) says pip install -e ."""
from __future__ import annotations

import importlib.metadata
import os
import pkgutil
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

from rvn_data.benchmark.policy_registry import POLICIES_GROUP, registered_policies
from rvn_data.benchmark.runner import make_policy
from rvn_data.config import CONF_DIR

POLICY_CONFS = sorted(Path(CONF_DIR, "policy").glob("*.yaml"))
OWN_POLICY = ("class OwnPolicy:\n    def __init__(self, **kw):\n        self.kw = kw\n"
              "    def reset(self):\n        pass\n    def act(self, obs):\n        return 0\n")


def test_every_policy_config_is_registered_under_its_name():
    """A new conf/policy/<name>.yaml needs its line in pyproject.toml's [project.entry-points."rvn.policies"]
    (then pip install -e .), with the value its _target_ names: module:attr == the dotted _target_."""
    registered = registered_policies()
    assert len(POLICY_CONFS) >= 5
    for path in POLICY_CONFS:
        target = yaml.safe_load(path.read_text())["_target_"]
        assert path.stem in registered, f"{path.name}: no entry point {POLICIES_GROUP} {path.stem!r} (pip install -e .?)"
        ep = registered[path.stem]
        assert f"{ep.module}.{ep.attr}" == target, (path.name, ep.value, target)
        assert ep.load() is pkgutil.resolve_name(target)


def test_registered_policy_is_loaded_through_its_entry_point(monkeypatch):
    loaded = []
    load = importlib.metadata.EntryPoint.load
    monkeypatch.setattr(importlib.metadata.EntryPoint, "load", lambda ep: loaded.append(ep.name) or load(ep))
    cfg = yaml.safe_load(Path(CONF_DIR, "policy", "goal_follower.yaml").read_text())
    policy = make_policy(cfg, None, "gf")
    assert loaded == ["goal_follower"] and type(policy).__name__ == "GoalFollowerPolicy"
    with pytest.raises(ValueError, match=r"policy 'gf': .*unexpected keyword argument 'stop_radiu'.*"
                                         r"policy\.\* settings: stop_radius, theta_step_deg \(nearest: stop_radius\)"):
        make_policy({**cfg, "stop_radiu": 1.0}, None, "gf")


def test_unimportable_target_is_one_line_naming_the_registered_policies(tmp_path):
    proc = subprocess.run([sys.executable, "-m", "rvn_data.benchmark.cli", "policy=random", "policy._target_=nosuch.Policy",
                           f"out_dir={tmp_path / 'out'}"], capture_output=True, text=True, cwd=tmp_path, timeout=300,
                          env={**os.environ, "OMP_NUM_THREADS": "1"})
    lines = proc.stderr.strip().splitlines()
    assert proc.returncode == 2 and len(lines) == 1, proc.stderr[-3000:]
    assert lines[0].startswith("rvn-eval: error: policy._target_=nosuch.Policy cannot be imported")
    assert f"registered policies (entry points {POLICIES_GROUP}): " + ", ".join(p.stem for p in POLICY_CONFS) in lines[0]
    assert sorted(p.name for p in tmp_path.iterdir()) == []


def test_unregistered_target_is_imported_by_its_dotted_path(tmp_path, monkeypatch):
    """A policy of one's own: built with plain settings (interpolations resolved, lists and dicts as such);
    rvn-eval's note for it: tests/test_eval.py::test_invalid_action_names_policy."""
    from omegaconf import OmegaConf

    (tmp_path / "ownpol.py").write_text(OWN_POLICY)
    monkeypatch.syspath_prepend(str(tmp_path))
    cfg = OmegaConf.create({"seed": 7, "policy": {"_target_": "ownpol.OwnPolicy", "seed": "${seed}",
                                                  "probs": [0.5, 0.5], "extra": {"a": (1, 2)}}})
    policy = make_policy(cfg.policy, None, "own")
    assert policy.kw == {"seed": 7, "probs": [0.5, 0.5], "extra": {"a": [1, 2]}}
    assert type(policy.kw["probs"]) is list and type(policy.kw["extra"]) is dict
    with pytest.raises(ValueError, match=r"policy\.extra\._target_: rvn-eval builds the policy's own _target_"):
        make_policy({"_target_": "ownpol.OwnPolicy", "extra": {"_target_": "ownpol.OwnPolicy"}}, None, "own")
    (tmp_path / "brokenpol.py").write_text("def Policy(:\n")
    with pytest.raises(ValueError, match=r"policy\._target_=brokenpol\.Policy cannot be imported \(.*\); registered"):
        make_policy({"_target_": "brokenpol.Policy"}, None, "broken")


def test_stale_metadata_says_pip_install(monkeypatch):
    """An install whose metadata predates the rvn.policies group (pip install -e . not rerun)."""
    entry_points = importlib.metadata.entry_points
    monkeypatch.setattr(importlib.metadata, "entry_points",
                        lambda **kw: [] if kw.get("group") == POLICIES_GROUP else entry_points(**kw))
    cfg = yaml.safe_load(Path(CONF_DIR, "policy", "oracle.yaml").read_text())
    with pytest.raises(ValueError, match=r"policy\._target_=rvn_data\.benchmark\.policies\.OraclePolicy "
                                         r"\(conf/policy/oracle\.yaml\) is not registered .*: none\).*pip install -e \."):
        make_policy(cfg, None, "oracle")
    with pytest.raises(ValueError, match=r"no package registers a policy .*pip install -e \."):
        make_policy({"_target_": "nosuch.Policy"}, None, "x")
