"""``import mfid``: the public API of :mod:`identify.api` under the project's name.

``mfid.fit`` is the in-memory fit (:func:`identify.api.fit`); in ``identify`` that name is the
``identify.fit`` sub-package, so the function is reached as ``identify.api.fit`` there.
"""
from identify import __all__ as _IDENTIFY_ALL
from identify import __getattr__ as _identify_getattr
from identify import __version__  # noqa: F401

__all__ = sorted({*_IDENTIFY_ALL, "fit"})


def __getattr__(name: str):
    if name == "fit":
        from identify import api

        return api.fit
    return _identify_getattr(name)


def __dir__() -> list[str]:
    return list(__all__)
