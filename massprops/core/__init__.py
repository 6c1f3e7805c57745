"""Compiled kernels and the thin Python faces that call them."""
