"""The monitoring service the nodes and the replay share, history, node config."""
