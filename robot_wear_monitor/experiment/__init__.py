"""The friction experiment: segmentation (3), friction-level types, simulation."""
