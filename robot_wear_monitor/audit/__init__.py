"""Closing the loop: residual structure, traced effects, before/after errors."""
