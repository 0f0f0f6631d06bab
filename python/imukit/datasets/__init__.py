"""Readers for public labelled datasets, returning arrays in imukit's units (SI, w x y z)."""
