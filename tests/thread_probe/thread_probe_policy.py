"""A policy for tests/test_worker_threads.py (on PYTHONPATH only there): it stops at once, and its
``episode_stats`` report the CPU threads OpenCV and torch use in the process that built it, and the compile
processes torch.compile would start there."""
import cv2
import torch
from torch._inductor import config

from rvn_data.conventions import Action


class ThreadProbePolicy:
    def __init__(self, **settings):  # a policy config's other keys are not used
        self.seen = {"cv2_threads": cv2.getNumThreads(), "torch_threads": torch.get_num_threads(),
                     "compile_threads": config.compile_threads}

    def reset(self) -> None:
        pass

    def act(self, obs) -> int:
        return int(Action.STOP)

    def episode_stats(self) -> dict:
        return self.seen
