"""opends_gym: OpenDS driving tasks as fast, faithful Gymnasium environments.

Importing the package registers the `OpenDS/...` environment ids with Gymnasium.
"""

from .envs.registration import register_envs

__version__ = "0.1.0"

register_envs()

__all__ = ["__version__", "register_envs"]
