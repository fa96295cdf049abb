#!/usr/bin/env python3
"""Rewrite the wheel build box's include paths in the venv's exported CMake files.

The ROS 2 Jazzy wheels ship ``<venv>/share/*/cmake/*.cmake`` files whose imported targets
(e.g. ``std_msgs::std_msgs__rosidl_generator_py``) name the include directories of the machine
that built the wheels: ``/opt/python/cp311-cp311/include/python3.11`` and
``/opt/python/cp311-cp311/lib/python3.11/site-packages/numpy/_core/include``. CMake refuses to
configure a package that links such a target ("includes non-existent path"), so this script
points them at this venv's Python include directory and ``numpy.get_include()``.

It is idempotent (a rewritten file no longer matches) and must run again after every install of
ROS wheels, which brings the original files back. Run it with the venv's interpreter::

    .venv/bin/python tools/fix_wheel_cmake_paths.py
"""

from __future__ import annotations

import argparse
import os
import re
import sys
import sysconfig
import tempfile
from pathlib import Path

# Prefix of the manylinux build image's CPython installs, e.g. /opt/python/cp311-cp311.
_BUILD_PY = r"/opt/python/cp3\d+-cp3\d+"
_NUMPY_INCLUDE = re.compile(
    _BUILD_PY + r"/lib/python3\.\d+/site-packages/numpy/(?:_core|core)/include"
)
_PYTHON_INCLUDE = re.compile(_BUILD_PY + r"/include/python3\.\d+")


def rewrite(text: str, python_include: str, numpy_include: str) -> str:
    """Return ``text`` with the build box's Python and numpy include paths replaced."""
    text = _NUMPY_INCLUDE.sub(lambda _m: numpy_include, text)
    return _PYTHON_INCLUDE.sub(lambda _m: python_include, text)


def _write_atomically(path: Path, text: str) -> None:
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=path.name + ".", suffix=".tmp")
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as handle:
            handle.write(text)
        os.chmod(tmp, path.stat().st_mode & 0o7777)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def fix_prefix(prefix: Path, python_include: str, numpy_include: str) -> list[Path]:
    """Rewrite every ``prefix/share/*/cmake/*.cmake`` that needs it; return the changed files."""
    changed = []
    for path in sorted(prefix.glob("share/*/cmake/*.cmake")):
        text = path.read_text(encoding="utf-8")
        if "/opt/python/" not in text:
            continue
        new = rewrite(text, python_include, numpy_include)
        if new != text:
            _write_atomically(path, new)
            changed.append(path)
    return changed


def main(argv: list[str] | None = None) -> int:
    """Command-line entry point; returns the process exit code."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--prefix",
        type=Path,
        default=Path(sys.prefix),
        help="venv prefix holding share/*/cmake (default: this interpreter's, %(default)s)",
    )
    parser.add_argument("-v", "--verbose", action="store_true", help="list the rewritten files")
    args = parser.parse_args(argv)

    try:
        import numpy
    except ImportError:
        print(
            "fix_wheel_cmake_paths: numpy is not importable; run me with the venv's python",
            file=sys.stderr,
        )
        return 2
    python_include = sysconfig.get_paths()["include"]
    numpy_include = numpy.get_include()
    for needed in (python_include, numpy_include):
        if not Path(needed).is_dir():
            print(f"fix_wheel_cmake_paths: include dir missing: {needed}", file=sys.stderr)
            return 2

    changed = fix_prefix(args.prefix, python_include, numpy_include)
    print(
        f"fix_wheel_cmake_paths: rewrote {len(changed)} file(s) under {args.prefix}/share "
        f"(python: {python_include}, numpy: {numpy_include})"
    )
    if args.verbose:
        for path in changed:
            print(f"  {path}")
    leftover = [
        p
        for p in args.prefix.glob("share/*/cmake/*.cmake")
        if "/opt/python/" in p.read_text(encoding="utf-8")
    ]
    if leftover:
        print("fix_wheel_cmake_paths: unrecognised /opt/python paths remain in:", file=sys.stderr)
        for path in leftover:
            print(f"  {path}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
