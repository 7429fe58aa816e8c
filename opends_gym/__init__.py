"""opends_gym: OpenDS driving tasks as fast, faithful Gymnasium environments.

Importing the package registers the `OpenDS/...` environment ids with Gymnasium.
"""

from .envs.registration import register_envs
from .version import __version__

register_envs()

__all__ = ["__version__", "register_envs"]
