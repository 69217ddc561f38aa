"""Bundled scene files (TOML), installed as ``warp_cut.scenes``; copy one to start your own."""
