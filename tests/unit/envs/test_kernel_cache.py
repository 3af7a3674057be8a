"""The digest of a package's kernel modules (envs._kernel_cache) against numba's per-file cache.

A temporary package holds two kernel modules, ``_a_kernels.a`` calling ``_b_kernels.b``; each run is a
fresh interpreter (numba's in-memory dispatchers would hide the disk cache).  After ``b`` changes,
numba alone loads ``a`` with the old ``b`` from its cache; with :func:`envs._kernel_cache.refresh` in
the package's ``__init__.py`` the cache is dropped and ``a`` sees the new ``b``.  Both with the cache
beside the modules and in ``NUMBA_CACHE_DIR``.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from envs._kernel_cache import DIGEST_NAME, cache_directories, kernel_modules, source_digest

REPO = Path(__file__).resolve().parents[3]
CALLER = "import numba\nfrom kpkg._b_kernels import b\n\n\n@numba.njit(cache=True)\ndef a():\n    return b() + 1\n"
CALLEE = "import numba\n\n\n@numba.njit(cache=True)\ndef b():\n    return {value}\n"
HOOK = "from envs._kernel_cache import refresh\n\nrefresh(__file__)\n"


def _package(root: Path, hooked: bool) -> Path:
    package = root / "kpkg"
    package.mkdir()
    (package / "__init__.py").write_text(HOOK if hooked else "")
    (package / "_a_kernels.py").write_text(CALLER)
    (package / "_b_kernels.py").write_text(CALLEE.format(value=1))
    return package


def _run(root: Path, cache_dir: Path | None) -> int:
    env = {key: value for key, value in os.environ.items() if key != "NUMBA_CACHE_DIR"}
    env["PYTHONPATH"] = os.pathsep.join([str(root), str(REPO)])
    env["PYTHONDONTWRITEBYTECODE"] = "1"
    if cache_dir is not None:
        env["NUMBA_CACHE_DIR"] = str(cache_dir)
    code = "from kpkg._a_kernels import a; print(a())"
    done = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True)
    return int(done.stdout.split()[-1])


def _change_callee(package: Path) -> None:
    path = package / "_b_kernels.py"
    path.write_text(CALLEE.format(value=10))
    stat = path.stat()
    os.utime(path, ns=(stat.st_atime_ns, stat.st_mtime_ns + 2_000_000_000))


def _cached(package: Path, cache_dir: Path | None) -> list[Path]:
    directory = package / "__pycache__" if cache_dir is None else next(cache_dir.rglob("kpkg_*"))
    return sorted(directory.glob("_a_kernels.*.nbi"))


@pytest.mark.parametrize("numba_cache_dir", [False, True], ids=["in-tree", "NUMBA_CACHE_DIR"])
def test_a_changed_callee_is_stale_without_the_digest_and_fresh_with_it(tmp_path, numba_cache_dir):
    for hooked, expected in ((False, 2), (True, 11)):
        root = tmp_path / ("hooked" if hooked else "plain")
        root.mkdir()
        cache_dir = root / "numba-cache" if numba_cache_dir else None
        package = _package(root, hooked)
        assert _run(root, cache_dir) == 2
        assert _cached(package, cache_dir), "numba cached the caller"
        _change_callee(package)
        assert _run(root, cache_dir) == expected
        assert _run(root, cache_dir) == expected  # and cached again, now fresh


def test_an_unchanged_package_keeps_its_cache(tmp_path):
    package = _package(tmp_path, hooked=True)
    assert _run(tmp_path, None) == 2
    before = {path: path.stat().st_mtime_ns for path in (package / "__pycache__").glob("*.nb[ic]")}
    assert before
    assert _run(tmp_path, None) == 2
    after = {path: path.stat().st_mtime_ns for path in (package / "__pycache__").glob("*.nb[ic]")}
    assert after == before


def test_the_digest_covers_the_kernel_modules_only(tmp_path):
    package = _package(tmp_path, hooked=True)
    (package / "plain.py").write_text("X = 1\n")
    modules = kernel_modules(package)
    assert [path.name for path in modules] == ["_a_kernels.py", "_b_kernels.py"]
    digest = source_digest(modules)
    (package / "plain.py").write_text("X = 2\n")
    assert source_digest(kernel_modules(package)) == digest
    (package / "_b_kernels.py").write_text(CALLEE.format(value=3))
    assert source_digest(kernel_modules(package)) != digest


def test_the_package_directories_hold_the_digest():
    import envs.analysis

    package = Path(envs.analysis.__file__).parent
    stored = [directory / DIGEST_NAME for directory in cache_directories(package) if (directory / DIGEST_NAME).exists()]
    assert stored
    assert all(path.read_text().strip() == source_digest(kernel_modules(package)) for path in stored)
