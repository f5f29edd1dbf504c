"""Atomic file writes: a failed or interrupted write leaves no partial file behind."""
from __future__ import annotations

import contextlib
import os
import shutil
import tempfile


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def _new_file_mode() -> int:
    return 0o666 & ~_umask()


@contextlib.contextmanager
def atomic_path(path):
    """Yield a temporary path beside `path` (same extension); on success rename it over `path`."""
    path = os.fspath(path)
    directory = os.path.dirname(os.path.abspath(path))
    if not os.path.isdir(directory):
        raise OSError(f"{path}: cannot write, directory {directory} does not exist")
    # The temporary name keeps the real extension: OpenImageIO picks the format from it.
    base, ext = os.path.splitext(os.path.basename(path))
    fd, tmp = tempfile.mkstemp(prefix=f".{base}.", suffix=f".tmp{ext}", dir=directory)
    os.close(fd)
    try:
        yield tmp
        os.chmod(tmp, _new_file_mode())  # mkstemp makes 0600; give the usual 0666 & ~umask
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


@contextlib.contextmanager
def atomic_directory(path):
    """Yield a temporary directory beside `path`; on success its files take their place in `path`.

    A new `path` appears whole (one rename); into an existing directory (an earlier report) the
    files are moved one by one, the HTML pages last. On failure or Ctrl-C the temporary directory
    is removed and `path` is left as it was.
    """
    path = os.fspath(path)
    directory = os.path.dirname(os.path.abspath(path))
    if not os.path.isdir(directory):
        raise OSError(f"{path}: cannot write, directory {directory} does not exist")
    if os.path.exists(path) and not os.path.isdir(path):
        raise OSError(f"{path}: cannot write a report there, it is a file")
    tmp = tempfile.mkdtemp(prefix=f".{os.path.basename(os.path.abspath(path))}.", suffix=".tmp",
                           dir=directory)
    try:
        yield tmp
        os.chmod(tmp, 0o777 & ~_umask())  # mkdtemp makes 0700; give the usual 0777 & ~umask
        try:
            os.rename(tmp, path)   # atomic when path is missing or an empty directory
        except OSError:
            for name in sorted(os.listdir(tmp), key=lambda n: (n.endswith(".html"), n)):
                os.replace(os.path.join(tmp, name), os.path.join(path, name))
            os.rmdir(tmp)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
