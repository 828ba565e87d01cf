"""RVN imitation-learning side: GNM data, models, policies, training, closed-loop eval."""
__version__ = "0.1.0"
