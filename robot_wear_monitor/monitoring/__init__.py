"""The monitoring services the nodes and the replay share, diagnostics, history, node config."""
