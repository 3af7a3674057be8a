"""Numba's on-disk cache of a package's kernels, dropped whenever any of their source files changes.

numba caches a compiled function (``cache=True``) beside its module and checks only the source of
the module that defines it: a kernel that calls (or inlines) a kernel of another module, or reads one
of its constants, would keep a stale copy when only that other module changes.  Each package with
kernels calls :func:`refresh` in its ``__init__.py``, before any of its modules compiles or loads a
kernel: a sha256 digest of the package's kernel modules (every module of the package with
``cache=True``) is compared with the digest stored beside each of numba's cache directories of the
package, and on a mismatch (or none stored) that directory's cache files of those modules are
removed and the new digest written.  So a kernel may call kernels of other modules of its own
package; a kernel never calls one of another package.

It only removes cache files, so it never changes a number: a removed kernel is compiled again on its
next call.  Two processes may both remove the files and both write the digest (written atomically,
by a rename); the worst case is one more compilation.
"""

from __future__ import annotations

import hashlib
import os
import tempfile
from pathlib import Path

__all__ = ["DIGEST_NAME", "cache_directories", "kernel_modules", "refresh", "source_digest"]

DIGEST_NAME = "kernel-sources.sha256"
"""The file, in each cache directory, holding the digest of the kernel modules cached there."""


def kernel_modules(package: Path) -> list[Path]:
    """The package's modules whose kernels numba caches on disk (those with ``cache=True``), sorted."""
    return sorted(path for path in package.glob("*.py") if b"cache=True" in path.read_bytes())


def source_digest(modules: list[Path]) -> str:
    """The sha256 of the modules' names and contents, in the given order."""
    digest = hashlib.sha256()
    for path in modules:
        content = path.read_bytes()
        digest.update(f"{path.name}\0{len(content)}\0".encode())
        digest.update(content)
    return digest.hexdigest()


def cache_directories(package: Path) -> list[Path]:
    """Every directory where numba may cache the package's kernels: ``NUMBA_CACHE_DIR``'s subdirectory
    for the package, its ``__pycache__`` and the user-wide cache, in the order numba tries them
    (``numba.core.caching._CacheImpl``)."""
    from numba.core import config
    from numba.core.caching import _CacheLocator
    from numba.misc.appdirs import AppDirs

    subpath = _CacheLocator.get_suitable_cache_subpath(str(package / "__init__.py"))
    directories = [Path(config.CACHE_DIR) / subpath] if config.CACHE_DIR else []
    directories.append(package / "__pycache__")
    directories.append(Path(AppDirs(appname="numba", appauthor=False).user_cache_dir) / subpath)
    return directories


def refresh(package: str | os.PathLike) -> None:
    """Remove the cached kernels of the package (a directory, or a file of it such as its
    ``__init__.py``) from every cache directory whose stored digest is not that of the kernel
    modules now, and store the digest there."""
    package = Path(os.path.abspath(package))  # as numba names the source (no symlinks resolved)
    if package.is_file():
        package = package.parent
    modules = kernel_modules(package)
    digest = source_digest(modules)
    found = False
    for directory in cache_directories(package):
        if not found:  # the first writable one is numba's: made now, so that its digest predates its caches
            try:
                directory.mkdir(parents=True, exist_ok=True)
                found = os.access(directory, os.W_OK)
            except OSError:
                continue
        if directory.is_dir():
            _refresh_directory(directory, [path.stem for path in modules], digest)


def _refresh_directory(directory: Path, stems: list[str], digest: str) -> None:
    stored = directory / DIGEST_NAME
    try:
        if stored.read_text().strip() == digest:
            return
    except OSError:
        pass
    for stem in stems:
        for pattern in (f"{stem}.*.nbi", f"{stem}.*.nbc"):
            for path in directory.glob(pattern):
                try:
                    path.unlink()
                except FileNotFoundError:  # removed by another process
                    pass
                except OSError:  # not ours to remove: numba does not use a directory it cannot write
                    return
    try:
        handle, temporary = tempfile.mkstemp(dir=directory, prefix=DIGEST_NAME, suffix=".tmp")
        with os.fdopen(handle, "w") as file:
            file.write(digest + "\n")
        os.replace(temporary, stored)
    except OSError:
        pass
