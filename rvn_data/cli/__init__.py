"""Command-line tools of rvn_data (`rvn-scene`)."""
