"""BO2 Lighting: the extension's entry point; everything lives in ``addon/``."""
from .addon import register, unregister  # noqa: F401
