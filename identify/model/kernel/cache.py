"""numba's on-disk cache for the kernel, invalidated by a change to ANY kernel module.

numba keys a cached function on its own source file only; the kernel's loops inline functions
from the other modules of this package, so an edit there would leave a stale compiled loop in
the cache. These locators stamp every kernel function with all kernel modules' sizes and times.
Importing this module registers them (first in numba's list); other functions are unaffected.
"""
from __future__ import annotations

import os
from pathlib import Path

from numba.core import caching

KERNEL_SOURCES = tuple(sorted(str(p) for p in Path(__file__).parent.glob("*.py")))


class _KernelStampMixin:
    """Source stamp = (mtime, size) of every kernel module, for kernel functions only."""

    def get_source_stamp(self):
        return tuple((os.stat(p).st_mtime, os.stat(p).st_size) for p in KERNEL_SOURCES)

    @classmethod
    def from_function(cls, py_func, py_file):
        if os.path.abspath(py_file) not in KERNEL_SOURCES:
            return None
        return super().from_function(py_func, py_file)


def _numba(name: str):
    # public names since numba 0.61, underscored before
    return getattr(caching, name, None) or getattr(caching, "_" + name)


class KernelUserProvidedLocator(_KernelStampMixin, _numba("UserProvidedCacheLocator")):
    """NUMBA_CACHE_DIR set."""


class KernelInTreeLocator(_KernelStampMixin, _numba("InTreeCacheLocator")):
    """__pycache__ beside the module."""


class KernelUserWideLocator(_KernelStampMixin, _numba("UserWideCacheLocator")):
    """Read-only installs: the user's cache directory."""


_LOCATORS = _numba("CacheImpl")._locator_classes
if KernelInTreeLocator not in _LOCATORS:
    _LOCATORS[:0] = [KernelUserProvidedLocator, KernelInTreeLocator, KernelUserWideLocator]
