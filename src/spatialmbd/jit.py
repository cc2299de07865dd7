"""Just-in-time compilation of the hot path with Numba.

Every per-step kernel (constraint equations, body terms, the structured linear solves) is
written once, as plain Python over scalars and small tuples, and compiled with :func:`njit`.
Compiled code is cached on disk (``cache=True``), so the compile time (minutes for the whole
hot path: ``spatialmbd warmup`` takes 275 s on a 2-core machine) is paid once per machine and
Python version; later processes load the machine code in about a second.

Cache location and freshness: Numba keys a cached function on its own source file only, so a
change to a function it calls in another file would go unnoticed. The library's functions are
therefore cached under a directory named after a hash of all hot-path sources
(``<package>/__pycache__/numba-<hash>``, or the user cache directory when the package is not
writable, or ``$NUMBA_CACHE_DIR/spatialmbd-<hash>``): any edit compiles afresh.

Numba is a regular dependency (binary wheels, no compiler needed). Without it -- or with the
environment variable ``NUMBA_DISABLE_JIT=1`` -- the same functions run as ordinary Python:
correct, but one to two orders of magnitude slower.

Options: ``error_model="numpy"`` (a division by zero gives inf/NaN as in NumPy instead of
raising), no bounds checking, ``nogil``. ``fastmath`` is off: results match NumPy's IEEE
arithmetic.
"""
from __future__ import annotations

import hashlib
import os
import shutil

try:                                   # pragma: no cover - exercised by the install
    import numba as _numba
except ImportError:                    # pragma: no cover
    _numba = None

ENABLED = _numba is not None and not getattr(getattr(_numba, "config", None),
                                             "DISABLE_JIT", False)

_OPTIONS = dict(cache=True, nogil=True, error_model="numpy", boundscheck=False)

_PKG = os.path.dirname(os.path.abspath(__file__))
#: the sources of compiled code (and of everything it calls), relative to the package: every
#: module that compiles a function (tests/dynamics/test_layout.py checks that none is missing,
#: since the cache locator keys every function of the package by this list's hash only)
HOT_PATH = ("jit.py", "rotations", "state.py", "broadphase.py", "rank.py", "results.py",
            "constraints", "forces", "dynamics", "integrators", "sweep/batch/kernels.py",
            "sweep/outputs.py", "design/adjoint_kernels.py", "design/adjoint_vjp.py",
            "fmi/joint_kernel.py")


def hot_path_files() -> list:
    """Every source file of the hot path: the listed modules, and every module of the listed
    packages and of their subpackages (forces/contact, ...), relative to the package."""
    out = []
    for entry in HOT_PATH:
        path = os.path.join(_PKG, entry)
        files = [path] if path.endswith(".py") else sorted(
            os.path.join(root, f) for root, _, names in os.walk(path) for f in names
            if f.endswith(".py"))
        out += [os.path.relpath(f, _PKG) for f in files]
    return out


def _source_hash() -> str:
    h = hashlib.sha256(getattr(_numba, "__version__", "").encode())
    for rel in hot_path_files():
        h.update(rel.encode())
        with open(os.path.join(_PKG, rel), "rb") as fh:
            h.update(fh.read())
    return h.hexdigest()[:16]


_STAMP = None


def _stamp() -> str:
    global _STAMP
    if _STAMP is None:
        _STAMP = _source_hash()
    return _STAMP


def _roots():
    """Candidate cache directories, best first: (path, prune older siblings)."""
    stamp = _stamp()
    if os.environ.get("NUMBA_CACHE_DIR"):
        yield os.path.join(os.environ["NUMBA_CACHE_DIR"], f"spatialmbd-{stamp}"), False
    yield os.path.join(_PKG, "__pycache__", f"numba-{stamp}"), True
    try:
        from numba.misc.appdirs import AppDirs
        base = AppDirs(appname="spatialmbd", appauthor=False).user_cache_dir
    except ImportError:                 # pragma: no cover - without Numba
        base = os.path.join(os.path.expanduser("~"), ".cache", "spatialmbd")
    yield os.path.join(base, f"numba-{stamp}"), True


#: directories holding generated sources (their compiled code is cached like the package's)
_GENERATED_DIRS: set = set()


def generated_module(name: str, source: str):
    """Import generated source code (e.g. the constraint dispatch) from a file in the compile
    cache, so that Numba caches its compiled functions across processes.

    The file lives in the first writable cache directory of the current source hash and is
    rewritten (atomically) only when its content differs; without any writable directory the
    code is executed from memory (then compiled anew in each process)."""
    import importlib.util
    import sys
    import tempfile
    modname = f"spatialmbd._generated.{name}"
    for root, _ in _roots():
        path = os.path.join(root, f"{name}.py")
        try:
            os.makedirs(root, exist_ok=True)
            current = None
            if os.path.exists(path):
                with open(path, encoding="utf-8") as fh:
                    current = fh.read()
            if current != source:
                fd, tmp = tempfile.mkstemp(dir=root, prefix=f".{name}-", suffix=".py")
                with os.fdopen(fd, "w", encoding="utf-8") as fh:
                    fh.write(source)
                os.replace(tmp, path)
        except OSError:
            continue
        _GENERATED_DIRS.add(os.path.abspath(root))
        spec = importlib.util.spec_from_file_location(modname, path)
        module = importlib.util.module_from_spec(spec)
        sys.modules[modname] = module
        spec.loader.exec_module(module)
        return module
    import types
    module = types.ModuleType(modname)
    exec(compile(source, f"<generated {name}>", "exec"), module.__dict__)
    sys.modules[modname] = module
    return module


def dispatch_source(origin: str, function: str, args: str, call: str, kernels,
                    doc: str) -> str:
    """Source of a compiled dispatch generated from a registry: ``function(kind, args...)``
    loops over k and calls, for kind[k] == c, the kernel of entry c as ``kernel(call)``.

    kernels: (label, compiled function) in dispatch order; origin: who generates it (named in
    the file); the rest is the signature, the call's arguments and a one-line docstring."""
    lines = [f'"""Generated by {origin} from its registry; do not edit."""']
    for c, (label, fn) in enumerate(kernels):
        py = getattr(fn, "py_func", fn)
        lines.append(f"from {py.__module__} import {py.__name__} as _k{c}  # {label}")
    lines += ["from spatialmbd.jit import njit", "", "", "@njit",
              f"def {function}(kind, {args}):", f'    """{doc}"""',
              "    for k in range(kind.size):", "        c = kind[k]"]
    for c in range(len(kernels)):
        lines.append(f"        {'if' if c == 0 else 'elif'} c == {c}:")
        lines.append(f"            _k{c}({call})")
    if not kernels:
        lines.append("        pass")
    return "\n".join(lines) + "\n"


def _install_cache_locator() -> None:
    """Cache the package's compiled functions under a directory keyed by the source hash."""
    from numba.core import caching
    impl = getattr(caching, "CacheImpl", None) or getattr(caching, "_CacheImpl")
    stamp = _stamp()
    roots = _roots

    class Locator(caching._CacheLocator):
        def __init__(self, py_func, py_file, path):
            self._py_file = py_file
            self._lineno = py_func.__code__.co_firstlineno
            self._cache_path = path

        def get_cache_path(self):
            return self._cache_path

        def get_source_stamp(self):
            return stamp

        def get_disambiguator(self):
            return str(self._lineno)

        @classmethod
        def from_function(cls, py_func, py_file):
            here = os.path.abspath(py_file)
            if not (here.startswith(_PKG + os.sep)
                    or os.path.dirname(here) in _GENERATED_DIRS):
                return None
            for path, prune in roots():
                self = cls(py_func, py_file, path)
                try:
                    fresh = not os.path.isdir(path)
                    self.ensure_cache_path()
                except OSError:
                    continue
                if fresh and prune:
                    _prune(path)
                return self
            return None

    impl._locator_classes.insert(0, Locator)


def _prune(path: str) -> None:
    """Remove the caches of older sources next to ``path`` (best effort)."""
    parent, name = os.path.split(path)
    prefix = name.rsplit("-", 1)[0] + "-"
    for other in os.listdir(parent):
        if other.startswith(prefix) and other != name:
            shutil.rmtree(os.path.join(parent, other), ignore_errors=True)


if ENABLED:
    _install_cache_locator()


#: written into the cache directory by a completed ``spatialmbd warmup``
COMPLETE = "warmup-complete"


def cache_root():
    """The directory the cache locator uses for the current sources (the first candidate that
    is or can be made writable), or None."""
    for root, _ in _roots():
        if _usable(root):
            return root
    return None


def cache_is_warm(complete: bool = True) -> bool:
    """True when the whole hot path of the current sources is compiled on disk (a completed
    ``spatialmbd warmup`` left its mark), so a new process loads it in about a second instead
    of compiling (minutes, once per machine and version). complete=False: the core
    kernels (the constraint stage) are there, whatever else is (what the compile notice of an
    in-process run asks)."""
    if not ENABLED:
        return True
    root = cache_root()
    if root is None:
        return False
    if os.path.exists(os.path.join(root, COMPLETE)):
        return True
    if complete:
        return False
    try:
        names = os.listdir(root)
    except OSError:
        return False
    return any(n.startswith("system.") and n.endswith(".nbi") for n in names)


def mark_warm() -> None:
    """Record that the hot path is compiled (after ``spatialmbd warmup``)."""
    root = cache_root()
    if root is None:
        return
    os.makedirs(root, exist_ok=True)
    tmp = os.path.join(root, f".{COMPLETE}.{os.getpid()}")
    with open(tmp, "w") as fh:
        fh.write("compiled by spatialmbd warmup\n")
    os.replace(tmp, os.path.join(root, COMPLETE))


class warmup_lock:
    """Context manager: one ``spatialmbd warmup`` at a time per cache directory (a second one
    waits for the first, then loads what it compiled). A no-op where ``fcntl`` is missing."""

    def __enter__(self):
        self._fh = None
        root = cache_root()
        try:
            import fcntl
        except ImportError:                 # pragma: no cover - Windows
            return self
        if root is None:
            return self
        os.makedirs(root, exist_ok=True)
        self._fh = open(os.path.join(root, ".warmup.lock"), "w")
        fcntl.flock(self._fh, fcntl.LOCK_EX)
        return self

    def __exit__(self, *exc):
        if self._fh is not None:
            self._fh.close()                # releases the lock
        return False


def _usable(root: str) -> bool:
    """Whether ``root`` exists writable, or could be created (its nearest existing parent is
    writable): the cache locator's choice among the candidate directories."""
    path = root
    while not os.path.exists(path):
        parent = os.path.dirname(path)
        if parent == path:
            return False
        path = parent
    return os.path.isdir(path) and os.access(path, os.W_OK)


class compile_notice:
    """Context manager: when the compile cache is cold, say so at once and then every
    ``every`` seconds how long compiling has taken, on ``stream`` (stderr), until the block
    ends -- a first run is never silent. Does nothing when the cache is warm."""

    def __init__(self, stream=None, every: float = 5.0, force: bool = False):
        import sys
        self.stream = stream if stream is not None else sys.stderr
        self.every = every
        self.active = force or not cache_is_warm(complete=False)

    def __enter__(self):
        if not self.active:
            return self
        import threading
        import time
        self._start = time.perf_counter()
        self._done = threading.Event()
        self._say("compiling the numerical kernels for this machine (first run only; later "
                  "runs load them in about a second). `spatialmbd warmup` does this ahead.")

        def tick():
            while not self._done.wait(self.every):
                self._say(f"  ... still compiling ({time.perf_counter() - self._start:.0f} s)")
        self._thread = threading.Thread(target=tick, daemon=True)
        self._thread.start()
        return self

    def _say(self, text):
        try:
            print(text, file=self.stream, flush=True)
        except (OSError, ValueError):
            pass

    def __exit__(self, *exc):
        if self.active:
            import time
            self._done.set()
            self._thread.join()
            self._say(f"compiled in {time.perf_counter() - self._start:.0f} s (cached for "
                      "later runs)")
        return False


def njit(fn=None, **options):
    """``numba.njit`` with the library's options, or the identity without Numba."""
    if _numba is None:
        return fn if fn is not None else (lambda f: f)
    opts = dict(_OPTIONS)
    opts.update(options)
    if fn is None:
        return _numba.njit(**opts)
    return _numba.njit(**opts)(fn)


def array_view(B, offset, shape):
    """A C-contiguous view of B[offset:offset + prod(shape)] with the given shape (a tuple).

    In compiled code this is a plain pointer-and-shape construction without reference counting
    (``ndarray.reshape`` costs about 50 ns per call in Numba and every reference-counted view
    a few more on each function call, which adds up over the tens of views of an evaluation).
    The view must not outlive the compiled call and B must stay alive meanwhile (it does: the
    buffers are owned by the Python caller)."""
    size = 1
    for d in shape:
        size *= d
    return B[offset:offset + size].reshape(shape)


if _numba is not None:                 # pragma: no branch
    from numba.core import cgutils as _cgutils
    from numba.core import types as _types
    from numba.extending import intrinsic as _intrinsic
    from numba.extending import overload as _overload
    from numba.np.arrayobj import make_array as _make_array
    from numba.np.arrayobj import populate_array as _populate_array

    @_intrinsic
    def _view(typingctx, B, offset, shape):
        if not (isinstance(B, _types.Array) and B.layout == "C" and B.ndim == 1):
            raise _numba.core.errors.TypingError("array_view needs a C-contiguous 1-D array")
        nd = len(shape)
        rettype = _types.Array(B.dtype, nd, "C")
        sig = rettype(B, offset, shape)

        def codegen(context, builder, sig, args):
            src = _make_array(sig.args[0])(context, builder, args[0])
            out = _make_array(rettype)(context, builder)
            shapes = _cgutils.unpack_tuple(builder, args[2], nd)
            strides = [None] * nd
            acc = src.itemsize
            for d in reversed(range(nd)):
                strides[d] = acc
                acc = builder.mul(acc, shapes[d])
            off = context.cast(builder, args[1], sig.args[1], _types.intp)
            # no meminfo: the view is not reference counted (like numba.carray); the caller
            # keeps B alive while the view is used
            _populate_array(out, data=builder.gep(src.data, [off]), shape=shapes,
                            strides=strides, itemsize=src.itemsize, meminfo=None)
            return out._getvalue()
        return sig, codegen

    @_overload(array_view)
    def _view_overload(B, offset, shape):
        def impl(B, offset, shape):
            return _view(B, offset, shape)
        return impl
