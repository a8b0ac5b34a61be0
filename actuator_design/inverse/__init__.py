"""Inverse design of an ideal field (and shapes, several poses, stiffness): the main job."""
