"""Experiments on rendered datasets and synthetic data: relative pose from image pairs (one pair, and the benchmark of pairs),
noise sweeps, central versus non-central models. Each writes a report (JSON + Markdown + PNG)."""
