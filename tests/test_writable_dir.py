"""check_writable_dir (every CLI's out_dir check) when another process creates the same new
parent folder at the same moment: two trainings started side by side into OUT/train/..."""
from __future__ import annotations

import os
from pathlib import Path

import pytest

from rvn_data.cli.common import ConfigError, check_writable_dir


def test_a_parent_made_by_another_process_meanwhile_is_accepted_and_kept(tmp_path, monkeypatch):
    parent = tmp_path / "train"
    real_mkdir = Path.mkdir

    def lose_the_race(self, *args, **kwargs):
        if self == parent and not parent.exists():
            os.mkdir(parent)  # the other run got there first
            (parent / "ppo").mkdir()
            raise FileExistsError(17, "File exists", str(self))
        return real_mkdir(self, *args, **kwargs)

    monkeypatch.setattr(Path, "mkdir", lose_the_race)
    assert check_writable_dir(parent / "ppo_lag") == parent / "ppo_lag"
    assert parent.is_dir() and (parent / "ppo").is_dir()  # the other run's folders are left alone
    assert not (parent / "ppo_lag").exists()  # ours, made to find out, is removed again


def test_a_file_in_the_way_is_still_refused(tmp_path):
    (tmp_path / "train").write_text("")
    with pytest.raises(ConfigError, match="cannot write there"):
        check_writable_dir(tmp_path / "train" / "ppo")
