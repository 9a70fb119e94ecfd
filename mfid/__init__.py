"""``import mfid``: the same public API as ``import identify`` (the package's own name)."""
from identify import __all__, __getattr__, __version__  # noqa: F401
