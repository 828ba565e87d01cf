"""rvn-rl's own setting groups, every default here: ``env``, ``model``, ``ppo`` (`PPOConfig`, which `rvn_rl.ppo`
updates with), ``ddppo``, ``depth``, ``train`` and ``algo`` (the option files conf/rl/algo/*.yaml hold only what differs
from `AlgoConfig`). The whole tree, with the task side's groups, is `rvn_rl.config.RLConfig`.
Field order is the order of the composed config, and so of the config.yaml rvn-rl writes into its out_dir."""
from __future__ import annotations

from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Union

ALGOS = ("ppo", "ppo_lag", "ddppo", "ddppo_depth")


def at_least(name: str, value, minimum: int = 1) -> None:
    """A one-line ValueError naming the setting ``name`` unless ``value`` is an integer >= ``minimum``."""
    if isinstance(value, bool) or not isinstance(value, int) or value < minimum:
        what = "a positive integer" if minimum == 1 else f"an integer >= {minimum}"
        raise ValueError(f"{name}={value!r} must be {what}")
CONF_RL = Path(__file__).resolve().parents[1] / "conf" / "rl"  # the groups algo/ and scale/


@dataclass
class EnvSettings:
    """``env``: the train-mode environments of one process (of one rank for DD-PPO)."""

    num_envs: int = 4  # environments per process (per rank for DD-PPO)
    size: int = 256  # observation side (camera width = height), pixels
    num_scenes: int | None = None  # train scenes (null = all 800)
    scene_switch_every: int = 8  # resets of an env before it draws another scene (0: not by resets)
    # or at its first reset after this many steps in the scene (0: not by steps), whichever comes first: Habitat's
    # max_scene_repeat_steps (10,000 there, with max_scene_repeat_episodes off: scene_switch_every=0), each visit's
    # budget within +-20 %. A random policy's episode lasts ~25 steps (a collision ends it), so 8 resets switch every
    # ~200 steps, and each switch costs ~100 ms of a helper's CPU (scene, navmesh, goal pool read back): 2 processes
    # of 2 envs on the 2-core development CPU stepped 828 env steps/s so, 1,572 with 10,000 steps
    # (benchmarks/rl_env_phases.py)
    scene_switch_steps: int = 0
    # train goals from a fixed pool of this many per scene (0: a fresh goal and two Dijkstra solves per draw). A pool
    # costs one solve per goal and its fields' smoothing (1.45-1.95 s for 64 on a procedural apartment) the first time a
    # cache root sees its scene, then 50-85 ms to read back (<cache root>/goal_pools, rvn_data.benchmark.pool_cache),
    # and a goal draw is a lookup (~0.1 ms): 2-core CPU, 2 envs in one process, 200 scenes, random actions, prefetch:
    # 126 env steps/s with pools built at each visit, 362 read back (benchmarks/scene_prefetch.py)
    goal_pool: int = 64
    scene_cache: int = 2  # scenes each env keeps loaded besides the current one
    # each env has the scene of its next switch (navmesh, goal pool) prepared in a helper process of its own while it
    # steps (in the env's process, loading and Dijkstra take turns with its steps for the GIL): the same scenes and
    # episodes, without the ~0.4 s wait at a switch that holds up every env stepped with it (one scene more in memory,
    # one process more per env)
    prefetch_scenes: bool = True
    workers: int = 0  # env worker processes (0: step the envs in this process)
    t_max: int = 500  # steps allowed per goal
    # STOP far from the goal: a no-op that costs a step (false: the benchmark's rule, rvn-eval's default) or the end of
    # the episode, a failure (true: Habitat's PointNav, where any STOP ends it). With false a policy can wait out
    # its collisions: PPO-Lagrangian at small scale spent a third of its val steps on far STOPs
    # (docs/results/2026-12-06_rl_lag_ddppo). With true at that scale, a STOP at the first step is the safe episode:
    # PPO-Lagrangian collapsed to it within 10k env steps, PPO drifted toward it, and episodes of 1-2 steps switch
    # scenes every 8-16 steps, which halved collection (docs/results/2026-12-06_stop_far)
    stop_far_is_failure: bool = False
    depth: bool = False  # rendered depth in the observation (set by depth.source=true)


@dataclass
class ModelSettings:
    """``model``: `PointNavResNetPolicy`'s network (the paper's: half-width ResNet-50)."""

    backbone: str = "resnet50"  # resnet50 (half width: base_planes 32) | resnet18
    base_planes: int = 32
    ngroups: int = 16  # GroupNorm groups
    input_size: int = 128  # observations larger than this are average-pooled down to it
    hidden_size: int = 512
    rnn_layers: int = 2


@dataclass
class PPOConfig:
    """``ppo``: the PPO update (`rvn_rl.ppo.ppo_update`); the defaults are DD-PPO's PointNav hyperparameters."""

    clip_param: float = 0.2  # surrogate and value clipping
    ppo_epoch: int = 2  # epochs over each rollout
    num_mini_batch: int = 2  # mini-batches per epoch, each whole rollouts of some envs (at most env.num_envs)
    value_loss_coef: float = 0.5
    entropy_coef: float = 0.01
    lr: float = 2.5e-4  # Adam
    eps: float = 1e-5  # Adam
    max_grad_norm: float = 0.2  # gradient-norm clip
    num_steps: int = 128  # rollout length
    gamma: float = 0.99  # discount
    tau: float = 0.95  # GAE lambda
    # advantages standardised (mean and variance over every rank's rollout) before the update: off in DD-PPO's
    # PointNav (habitat-baselines' ddppo_pointnav.yaml: use_normalized_advantage False), on in scale=small
    use_normalized_advantage: bool = False
    use_clipped_value_loss: bool = True
    # decoupled PPO (Hilton et al. 2021): clip the ratio to the weights at the update's start (their log-probs
    # recomputed, one forward pass over the rollout without gradients) and weight the surrogate by their ratio to the
    # weights that acted. For train.overlap, whose rollouts are acted by the weights one update older, where the ratio
    # to those starts away from 1 and clipping takes smaller steps; synchronous PPO gives the same loss up to rounding.
    # Off: it did not lower overlap's CPK in two seeds (docs/results/2026-12-02_rl_overlap/)
    decoupled: bool = False
    # the rollout's values (GAE's advantages, the value targets) recomputed with the weights at the update's start, one
    # forward pass without gradients: with train.overlap those that acted are one update older. Synchronous PPO: the
    # same values up to rounding. With train.overlap it lowered overlap's extra collisions pooled over three seeds
    # (x0.89 against plain overlap, x1.07 against synchronous PPO), though not in every seed
    # (docs/results/2026-12-02_rl_overlap/): set both
    recompute_advantages: bool = False


@dataclass
class DDPPOSettings:
    """``ddppo``: torchrun ranks (algo=ddppo, ddppo_depth)."""

    sync_frac: float = 0.6  # straggler pre-emption: stop once this fraction of ranks finished
    backend: str = "auto"  # auto (nccl on GPU, gloo on CPU) | gloo | nccl


@dataclass
class DepthSettings:
    """``depth``: the 4th input channel of algo=ddppo_depth."""

    # model: predicted from RGB by depth.model_path | true: the rendered depth (depth.source=true reads as a boolean)
    source: Union[str, bool] = "model"
    model_path: str | None = None  # out_dir of python -m rvn_rl.depth.cli

    def __post_init__(self) -> None:
        if self.source is True:
            self.source = "true"


@dataclass
class TrainSettings:
    """``train``: how long, checkpoints, threads, the visual trunk's precision and compilation."""

    total_steps: Union[int, float] = 2_500_000_000  # env steps over all ranks (4e5 reads as a float: taken as 400000)
    checkpoint_every: int = 50  # updates between checkpoints
    keep_checkpoints: int = 2
    resume: bool = True  # continue from out_dir's latest checkpoint (false: refused where out_dir holds checkpoints)
    # another run's out_dir: a new out_dir starts from its latest checkpoint (weights, optimiser, multiplier, env steps
    # and updates, metrics.jsonl's rows) and trains on to train.total_steps, which counts the source's steps; the
    # source stays as it was evaluated. config.yaml's continued_from records the source and the code that trained it;
    # a rerun resumes the new out_dir's own checkpoints (`rvn_rl.checkpoint.continue_point`). E.g. a 400k run on to
    # 600k: train.continue_from=runs/rl/ppo train.total_steps=600000 out_dir=runs/rl/ppo_600k
    continue_from: str | None = None
    threads: int | None = None  # torch intra-op threads (null = torch's setting)
    # fp32 | bf16: the visual encoder (ResNet, compression, visual_fc) under torch.autocast(bfloat16) in rollouts and
    # updates; the LSTM, heads, losses, weights and optimiser stay float32. For GPUs with bf16 (Ampere on) and CPUs
    # with native bf16 (AVX512-BF16, AMX): on the 2-core development CPU (AVX512-BF16) a scale=small update took 16.2 s
    # in fp32 and 10.9 s in bf16 (benchmarks/rl_learner.py), the README's rvn-rl run 26 -> 36 env steps/s; a CPU
    # without them emulates bf16, slower. On an H200 slower at scale=small (an update x0.84: host-bound, autocast adds
    # launches; docs/results/2026-12-04_gpu4)
    precision: str = "fp32"
    # torch.compile of the visual trunk (ResNet, compression, visual_fc: `PointNavResNetPolicy.compile_visual`) in
    # rollouts and updates: the same losses to float rounding (tests/test_rl.py). For GPUs, with
    # compile_mode=reduce-overhead (its forward and backward replayed as CUDA graphs: on the third H200 run a mini-batch
    # of 480 took 69 ms for 0.45 TFLOP); on the 2-core development CPU it was not faster (the trunk's forward and
    # backward on 128 frames at 128²: 1,080 against 1,046 ms in float32, 773 against 549 in bf16). Kernels under
    # <cache root>/compiled
    compile: bool = False
    compile_mode: str = "reduce-overhead"  # default | reduce-overhead (CUDA graphs on a GPU; on a CPU as default)
    # learn while collecting: each PPO update runs in a learner thread while the envs collect the next rollout with
    # a copy of the weights from before it (one update of policy lag, as asynchronous PPO; PPO's ratio and clipping are
    # against the policy that acted), so an update's time is the longer of the two instead of their sum. For a GPU
    # node, where the learner and the envs use different hardware; one process only (not DD-PPO's ranks). The copy that
    # acts is not compiled (train.compile compiles the learner's trunk)
    overlap: bool = False
    # the rollouts' act (network, LSTM step, heads) replayed as one CUDA graph (`rvn_rl.graphed`), the action drawn
    # after it as the plain act draws it: the same actions. For a GPU, where an act of 30 envs was ~7.9 ms of host
    # launches against 1.8 ms of kernels (docs/results/2026-12-04_gpu4); on a CPU it acts as without it (a warning).
    # Off until a GPU run has measured it
    graph_act: bool = False
    # Sample Factory's double-buffered sampling: the env workers in two halves, one stepping while the policy acts for
    # the other (`rvn_rl.collect`), so an act's time hides behind the other half's step instead of adding to it; needs
    # env.workers >= 2. Each env's transitions are the plain loop's (on a CPU its actions too, to the byte; a GPU draws
    # them otherwise from the same probabilities). Two acts a step of half the envs each: for a GPU with
    # train.graph_act, where an act is a graph's replay; an act of host launches (~7.9 ms for 30 envs on the fourth
    # H200 run, 1.8 ms of it kernels) would take about as long for half the envs, so two halves' acts would cost more
    # than they hide; on a CPU slower (a warning). Off until a GPU run has measured it
    double_buffered: bool = False

    def __post_init__(self) -> None:
        if isinstance(self.total_steps, float) and self.total_steps.is_integer():
            self.total_steps = int(self.total_steps)


LAGRANGIAN = ("cost_limit", "lambda_init", "lambda_lr", "lambda_max")


@dataclass
class AlgoConfig:
    """``algo`` (conf/rl/algo/<name>.yaml): the algorithm; the defaults are PPO's."""

    name: str = "ppo"  # ppo | ppo_lag | ddppo | ddppo_depth
    distributed: bool = False  # DD-PPO: one rank per process under torchrun, a DDP replica each
    lagrangian: bool = False  # PPO-Lagrangian: cost critic, cost GAE, lambda >= 0 by Adam on -lambda (J_c - cost_limit)
    use_depth: bool = False  # depth as a 4th input channel (depth.source)
    # PPO-Lagrangian only:
    cost_limit: float = 1.0e-4  # expected episode cost limit (the paper's)
    lambda_init: float = 0.001
    lambda_lr: float = 0.035
    lambda_max: float | None = None  # upper bound on lambda (null: none; jobs/rl_small.sh uses 1.0)

    def record(self) -> dict:
        """As config.yaml records it: the Lagrangian settings only for a Lagrangian algorithm, where they act."""
        return {k: v for k, v in asdict(self).items() if self.lagrangian or k not in LAGRANGIAN}
