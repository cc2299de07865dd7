"""Files written atomically: a temporary next to the target, fsync, then os.replace.

A reader never sees a half-written file at its final path, a failed or interrupted write
leaves the previous file in place, and the temporaries of a killed writer are removed by the
next write of the same target. Used for every file spatialmbd writes (results, plots,
animations, model files); it sits in the core layer so that any layer may use it.
"""
from __future__ import annotations

import contextlib
import os
import pathlib
import tempfile

__all__ = ["atomic_write", "clean_stale_temporaries", "STALE_SECONDS"]


def _default_mode() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return 0o666 & ~mask


#: temporaries of a killed writer older than this (s) are removed by the next write of the
#: same target even when their process id cannot be checked
STALE_SECONDS = 3600.0


def _pid_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except (PermissionError, OSError):
        return True
    return True


def clean_stale_temporaries(path) -> list:
    """Remove the hidden temporaries ``.<name>.<pid>.*.tmp`` of ``path`` left by a writer
    that was killed (its process no longer exists, or older than STALE_SECONDS); returns
    the removed paths."""
    import time
    path = pathlib.Path(path)
    directory = path.parent if str(path.parent) else pathlib.Path(".")
    removed = []
    prefix = f".{path.name}."
    try:
        entries = list(os.scandir(directory))
    except OSError:
        return removed
    for entry in entries:
        name = entry.name
        if not (name.startswith(prefix) and name.endswith(".tmp")):
            continue
        middle = name[len(prefix):-4].split(".", 1)[0]
        try:
            stale = not _pid_alive(int(middle)) if middle.isdigit() else \
                time.time() - entry.stat().st_mtime > STALE_SECONDS
        except OSError:
            continue
        if stale:
            with contextlib.suppress(OSError):
                os.unlink(entry.path)
                removed.append(pathlib.Path(entry.path))
    return removed


class _Staged:
    """A temporary file next to ``path`` (``.<name>.<pid>.<random>.tmp``), moved onto it by
    :meth:`commit` (fsync, then os.replace) or removed by :meth:`abort`."""

    def __init__(self, path):
        self.path = pathlib.Path(path)
        self.directory = self.path.parent if str(self.path.parent) else pathlib.Path(".")
        if not self.directory.is_dir():
            raise FileNotFoundError(f"cannot write {self.path}: directory {self.directory} "
                                    "does not exist")
        clean_stale_temporaries(self.path)
        fd, tmp = tempfile.mkstemp(prefix=f".{self.path.name}.{os.getpid()}.", suffix=".tmp",
                                   dir=self.directory)
        os.close(fd)
        self.tmp = pathlib.Path(tmp)

    def commit(self):
        path, tmp = self.path, self.tmp
        mode = path.stat().st_mode & 0o777 if path.exists() else _default_mode()
        os.chmod(tmp, mode)
        fd = os.open(tmp, os.O_RDWR)
        try:
            os.fsync(fd)
        finally:
            os.close(fd)
        os.replace(tmp, path)
        with contextlib.suppress(OSError, AttributeError):        # make the rename durable
            dfd = os.open(self.directory, os.O_RDONLY)
            try:
                os.fsync(dfd)
            finally:
                os.close(dfd)

    def abort(self):
        with contextlib.suppress(OSError):
            self.tmp.unlink()


@contextlib.contextmanager
def atomic_write(path):
    """Yield a temporary path next to ``path``; on normal exit fsync it and ``os.replace`` it
    onto ``path``. On any exception (KeyboardInterrupt included) the temporary file is removed
    and ``path`` is left untouched. Temporaries left by a killed writer of the same target are
    removed first (:func:`clean_stale_temporaries`). Errors of the file system (a full disk,
    a file-size limit) are raised as OSError naming the file; the previous file is kept."""
    staged = _Staged(path)
    try:
        yield staged.tmp
        staged.commit()
    except BaseException as exc:
        staged.abort()
        if isinstance(exc, OSError) and str(staged.path) not in str(exc):
            raise OSError(exc.errno, f"cannot write {staged.path}: {exc.strerror or exc} "
                                     "(the previous file, if any, is kept)") from exc
        raise
