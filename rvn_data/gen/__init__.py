"""`rvn-gen`: trajectory dataset generation (CLI, sharding, workers, summary)."""
