"""The Gymnasium environment (single and vectorised) and its compiled step kernel."""

from .contouring_env import ContouringEnv
from .core import EnvConfig, EnvCore
from .vector_env import ContouringVectorEnv

__all__ = ["ContouringEnv", "ContouringVectorEnv", "EnvConfig", "EnvCore"]
