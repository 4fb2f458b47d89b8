"""Figures, the replay report and the demo."""
