"""Plots (matplotlib, written to files; no display needed)."""
