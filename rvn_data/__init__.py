"""RVN task side: scenes, navmesh, simulator, renderer, planning, datasets, benchmark.

Task code never imports model code (`rvn_il`).
"""
__version__ = "0.1.0"
