"""Outputs: atomic files (``files``: JSON, CSV, PLY), USD playback export and its checker
(``usd_export``, ``usd_check``) and pictures (``plots``)."""
