"""Session set-up: the numerical kernels are compiled (or loaded from the cache) once, before
the first test, so that ``pytest --durations`` shows what each test costs rather than which
test happened to compile a kernel first."""
import pytest


@pytest.fixture(scope="session", autouse=True)
def compiled_kernels():
    from spatialmbd.cli import main
    assert main(["warmup", "--quiet"]) == 0
