"""Cleaning: self-similarity detection and repair, filters, inverse kinematics."""
