"""Figures: pure functions of results; the only importer of matplotlib."""
