"""Estimation of (T, w) (16)-(19), experiment design (22)-(25), Monte Carlo study."""
