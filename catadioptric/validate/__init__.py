"""Experiments on rendered datasets and synthetic data: relative rotation from image pairs,
noise sweeps, central versus non-central models. Each writes a report (JSON + Markdown + PNG)."""
