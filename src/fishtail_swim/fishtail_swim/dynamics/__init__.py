"""Planar rigid-body swimming driven by the tail (numpy only; see docs/swimming-dynamics.md)."""
