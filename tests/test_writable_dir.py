"""check_writable_dir (every CLI's out_dir check): it makes and removes no folder, so two runs started side by side
into one new parent folder (OUT/train/...) cannot remove each other's folders mid-creation; bad paths are refused."""
from __future__ import annotations

import os
from pathlib import Path

import pytest

from rvn_data.cli.common import ConfigError, check_writable_dir


def test_a_new_folder_is_checked_without_making_or_removing_a_folder(tmp_path, monkeypatch):
    """The old check made the missing folders and removed them again: its rmdir of a new parent it had made raced
    another run's ``mkdir(parents=True)`` of a folder inside it (``No such file or directory``)."""
    def no_folders(*args, **kwargs):
        raise AssertionError("check_writable_dir made or removed a folder")

    for name in ("mkdir", "rmdir", "makedirs", "removedirs"):
        monkeypatch.setattr(os, name, no_folders)
    monkeypatch.setattr(Path, "mkdir", no_folders)
    monkeypatch.setattr(Path, "rmdir", no_folders)
    assert check_writable_dir(tmp_path / "train" / "ppo_lag") == tmp_path / "train" / "ppo_lag"
    assert check_writable_dir(tmp_path) == tmp_path
    monkeypatch.undo()
    assert os.listdir(tmp_path) == []  # no probe file left behind either


def test_a_parent_another_run_is_making_is_left_to_it(tmp_path):
    parent = tmp_path / "train"
    assert check_writable_dir(parent / "ppo_lag") == parent / "ppo_lag"
    (parent / "ppo").mkdir(parents=True)  # the other run's folders
    assert check_writable_dir(parent / "ppo_lag") == parent / "ppo_lag"
    assert sorted(os.listdir(parent)) == ["ppo"] and not (parent / "ppo_lag").exists()


def test_a_file_in_the_way_is_still_refused(tmp_path):
    (tmp_path / "train").write_text("")
    with pytest.raises(ConfigError, match="cannot write there .*train is a file, not a folder"):
        check_writable_dir(tmp_path / "train" / "ppo")
    with pytest.raises(ConfigError, match="is a file, not a folder; choose a folder for out_dir"):
        check_writable_dir(tmp_path / "train")


@pytest.mark.skipif(os.geteuid() == 0, reason="root writes into read-only folders")
def test_a_read_only_parent_is_refused(tmp_path):
    ro = tmp_path / "ro"
    ro.mkdir()
    ro.chmod(0o555)
    try:
        with pytest.raises(ConfigError, match="cannot write there"):
            check_writable_dir(ro / "new" / "run")
    finally:
        ro.chmod(0o755)
