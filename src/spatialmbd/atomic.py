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

__all__ = ["atomic_write", "clean_stale_temporaries", "check_writable", "commit_all", "write_error",
           "interrupt_points", "interrupt_check", "defers_interrupts",
           "STALE_SECONDS"]


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


def write_error(path, exc: BaseException, tmp=None,
                kept: str = "the previous file, if any, is kept") -> OSError:
    """An OSError ``cannot write <path>: <reason> (<kept>)`` for ``exc`` raised while writing
    ``path`` (through its temporary ``tmp``): it names the target, never the hidden temporary
    (the reason is the system's text; a temporary's name in it is replaced by the target's)."""
    reason = getattr(exc, "strerror", None) or str(exc) or type(exc).__name__
    if tmp is not None:
        reason = reason.replace(str(tmp), str(path)).replace(pathlib.Path(tmp).name,
                                                             pathlib.Path(path).name)
    prefix = f"cannot write {path}: "
    message = reason if reason.startswith(prefix) else prefix + reason
    if kept and "kept)" not in message:
        message += f" ({kept})"
    error = OSError(message)              # str(error) is the message, without "[Errno n]"
    error.errno = getattr(exc, "errno", None)
    return error


def check_writable(path) -> None:
    """Create and remove the temporary of ``path``: raises OSError naming ``path`` when it
    cannot be written (a directory that does not exist, is read-only or is not a directory,
    /proc, ...), before any work is done."""
    _Staged(path).abort()


class _Staged:
    """A temporary file next to ``path`` (``.<name>.<pid>.<random>.tmp``), moved onto it by
    :meth:`commit` (fsync, then os.replace) or removed by :meth:`abort`."""

    def __init__(self, path):
        self.path = pathlib.Path(path)
        self.directory = self.path.parent if str(self.path.parent) else pathlib.Path(".")
        if not self.directory.is_dir():
            what = "is not a directory" if self.directory.exists() else "does not exist"
            raise FileNotFoundError(f"cannot write {self.path}: directory {self.directory} "
                                    f"{what}")
        if self.path.is_dir():
            raise IsADirectoryError(f"cannot write {self.path}: it is a directory")
        clean_stale_temporaries(self.path)
        try:
            fd, tmp = tempfile.mkstemp(prefix=f".{self.path.name}.{os.getpid()}.",
                                       suffix=".tmp", dir=self.directory)
        except OSError as exc:
            raise write_error(self.path, exc, kept="") from exc
        os.close(fd)
        self.tmp = pathlib.Path(tmp)

    def commit(self):
        """fsync the temporary and move it onto the target; on any failure (a refused rename,
        a full disk at fsync) the temporary is removed and the OSError names the target."""
        path, tmp = self.path, self.tmp
        try:
            mode = path.stat().st_mode & 0o777 if path.exists() else _default_mode()
            os.chmod(tmp, mode)
            fd = os.open(tmp, os.O_RDWR)
            try:
                os.fsync(fd)
            finally:
                os.close(fd)
            os.replace(tmp, path)
        except BaseException as exc:
            self.abort()
            if isinstance(exc, OSError):
                raise write_error(path, exc, tmp) from exc
            raise
        with contextlib.suppress(OSError, AttributeError):        # make the rename durable
            dfd = os.open(self.directory, os.O_RDONLY)
            try:
                os.fsync(dfd)
            finally:
                os.close(dfd)

    def abort(self):
        with contextlib.suppress(OSError):
            self.tmp.unlink()


def commit_all(staged) -> None:
    """Move every staged temporary onto its target; when one move fails, the temporaries not
    moved yet are removed too and the OSError names the target (and the files already
    moved)."""
    for k, st in enumerate(staged):
        try:
            st.commit()
        except BaseException as exc:
            for rest in staged[k + 1:]:
                rest.abort()
            if isinstance(exc, OSError) and k:
                done = ", ".join(str(s.path) for s in staged[:k])
                error = OSError(f"{exc}; already written: {done}")
                error.errno = exc.errno
                raise error from exc
            raise


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
        if isinstance(exc, OSError):
            raise write_error(staged.path, exc, staged.tmp) from exc
        raise


# ----------------------------------------------------------------------------------------------
# Ctrl-C while writing
# ----------------------------------------------------------------------------------------------
class _Deferred:
    """The SIGINT handler of :func:`interrupt_points`: it records the signal; the writer raises
    KeyboardInterrupt at its next :func:`interrupt_check`. (Raised from the handler directly,
    the KeyboardInterrupt can land in a callback of the HDF5 library -- h5py's object
    deallocation, its file-object driver -- where it is printed as "Exception ignored" and
    lost: the write then completed and the process exited 0.)"""

    depth = 0
    pending = False
    previous = None

    @classmethod
    def handler(cls, signum, frame):
        cls.pending = True


def interrupt_check() -> None:
    """Raise KeyboardInterrupt if Ctrl-C came since the last check (inside
    :func:`interrupt_points`; elsewhere nothing happens). Writers call it between blocks of at
    most a few MB, so an interrupt is honoured within well under a second."""
    if _Deferred.pending:
        _Deferred.pending = False
        raise KeyboardInterrupt("interrupted while writing")


def defers_interrupts(function=None, *, imports=()):
    """Decorator: run ``function`` inside :func:`interrupt_points`, after importing the
    modules ``imports`` (outside it: an import, pandas' takes 0.6 s, cannot be interrupted
    at an :func:`interrupt_check`)."""
    import functools
    import importlib
    if function is None:
        return lambda f: defers_interrupts(f, imports=imports)

    @functools.wraps(function)
    def wrapper(*args, **kwargs):
        for name in imports:
            importlib.import_module(name)
        with interrupt_points():
            return function(*args, **kwargs)
    return wrapper


@contextlib.contextmanager
def interrupt_points():
    """Within this block Ctrl-C (SIGINT) is raised only at :func:`interrupt_check` (and at the
    end of the block), never inside a library call. Only in the main thread and only when
    SIGINT has Python's default handler; otherwise (or nested) it changes nothing."""
    import signal
    import threading
    if _Deferred.depth:                                   # nested: the outer block decides
        _Deferred.depth += 1
        try:
            yield
        finally:
            _Deferred.depth -= 1
        return
    if threading.current_thread() is not threading.main_thread() or \
            signal.getsignal(signal.SIGINT) is not signal.default_int_handler:
        yield
        return
    _Deferred.pending = False
    _Deferred.previous = signal.signal(signal.SIGINT, _Deferred.handler)
    _Deferred.depth = 1
    try:
        yield
        if _Deferred.pending:           # Ctrl-C after the last check: the write is complete
            _Deferred.pending = False
            raise KeyboardInterrupt("interrupted after the write completed (the files are "
                                    "written)")
    finally:
        signal.signal(signal.SIGINT, _Deferred.previous)
        _Deferred.depth = 0
        _Deferred.pending = False
