"""The friction model: nominal (5), wear profile (7), complete (8); parameter sets."""
