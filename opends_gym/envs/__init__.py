"""Gymnasium environments over the shared simulation core."""

from .base import OpenDSEnv
from .registration import ENVS, register_envs

__all__ = ["ENVS", "OpenDSEnv", "register_envs"]
