"""Rotations and inverse kinematics (no knowledge of gaits or files)."""
