"""Session set-up: the numerical kernels are compiled (or loaded from the cache) once, before
the first test, so that ``pytest --durations`` shows what each test costs rather than which
test happened to compile a kernel first.

The tests mirror the package: tests/<subpackage>/ holds the tests of spatialmbd.<subpackage>,
tests/ itself those of the top-level modules and of the whole (docs, examples, CLI). Shared test
helpers (fd_check, fuzz_cases) live in tests/ and are importable from every directory."""
import os
import sys

import pytest

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))


@pytest.hookimpl(tryfirst=True)
def pytest_sessionstart(session):
    """Under pytest-xdist (scripts/test.sh runs ``-n auto``) the controller compiles every
    kernel once, before its workers start, so that they load them from the cache instead of
    each compiling them."""
    config = session.config
    if getattr(config, "workerinput", None) is None and config.getoption("numprocesses",
                                                                          default=None):
        from spatialmbd.cli import main
        assert main(["warmup", "--quiet"]) == 0


@pytest.fixture(scope="session", autouse=True)
def compiled_kernels():
    from spatialmbd.cli import main
    assert main(["warmup", "--quiet"]) == 0
