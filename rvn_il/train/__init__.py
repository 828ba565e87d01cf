"""rvn-train: training loop, EMA and the Hydra CLI."""
