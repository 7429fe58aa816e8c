"""The pybullet backend: the ego as a raycast vehicle on the task's scene (the `bullet` extra)."""
