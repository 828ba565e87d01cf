"""RL baselines on RVN-v0: PPO, PPO-Lagrangian, DD-PPO and DD-PPO with a depth channel
(habitat-baselines' PointNavResNetPolicy, a compact recurrent PPO trainer on torch.distributed).

``rvn-rl algo=ppo|ppo_lag|ddppo|ddppo_depth out_dir=... train.total_steps=... env.num_envs=...``;
a trained ``out_dir`` loads in ``rvn-eval policy=checkpoint policy.checkpoint_path=<out_dir>``.
"""
