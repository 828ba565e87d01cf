"""IL policies for rvn-eval: ``load_policy(checkpoint_path, device='cpu', **overrides)``."""
from .control import ControlConfig, waypoints_to_action
from .cor import cor, select_expert
from .loader import load_policy
from .policy import Member, NoMaDNegPolicy, PointGoalPolicy

__all__ = ["load_policy", "PointGoalPolicy", "NoMaDNegPolicy", "Member", "ControlConfig", "waypoints_to_action",
           "cor", "select_expert"]
