"""Polynomial kernels and the reflection-point solvers behind projection and vanishing points."""
