"""Session set-up: the numerical kernels are compiled (or loaded from the cache) once, before
the first test, so that ``pytest --durations`` shows what each test costs rather than which
test happened to compile a kernel first (in parallel runs: the common ones; see below).

The tests mirror the package: tests/<subpackage>/ holds the tests of spatialmbd.<subpackage>,
tests/ itself those of the top-level modules and of the whole (docs, examples, CLI). Shared test
helpers (fd_check, fuzz_cases) live in tests/ and are importable from every directory."""
import os
import sys

import pytest

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
# the CLI's cold-start race (a background compile and an interpreted child process) is tested
# on its own in test_cli.py; everywhere else commands run in-process as they are
os.environ["SPATIALMBD_NO_RACE"] = "1"


def _warm_kinematics():
    from spatialmbd import models
    from spatialmbd.kinematics import kinematic_analysis
    kinematic_analysis(models.slider_crank(crank_speed=6.0).compile(), [0.0, 0.01])


def _warm_dynamics(methods=("standard", "projection")):
    from spatialmbd import models
    from spatialmbd.simulate import simulate
    fly = models.flyball_governor().compile()
    for method in methods:
        simulate(fly, 1e-3, method=method, integrator="rk45", output_step=1e-3)


def _warm_recursive():
    from spatialmbd import models
    from spatialmbd.io import Analysis
    from spatialmbd.simulate import simulate
    from spatialmbd.sweep.batch import simulate_batch
    chain = models.chain(2, "revolute").compile()
    simulate(chain, 1e-3, method="recursive", output_step=1e-3)
    simulate_batch([chain], Analysis(t_end=1e-3, output_step=1e-3, method="recursive"))


def _warm_core(parallel=False):
    """Compile (or load) the kernels nearly every test uses: the constraint dispatch and
    kinematics, the standard and projection right-hand sides with the force dispatch. With
    ``parallel`` (the controller of a parallel run, whose workers wait for it) the kinematics
    and then the recursive method (the default for trees) compile in a second process at the
    same time (the cache writes are atomic; the second process is done well before the
    first)."""
    if not parallel:
        _warm_kinematics()
        _warm_dynamics()
        return
    import subprocess
    here = os.path.dirname(os.path.abspath(__file__))
    child = subprocess.Popen([sys.executable, "-c", "import conftest; "
                              "conftest._warm_kinematics(); conftest._warm_recursive()"],
                             cwd=here)
    _warm_dynamics()
    if child.wait() != 0:                 # compile them here then (the error shows in tests)
        _warm_kinematics()


def _parallel(config) -> bool:
    return bool(config.getoption("numprocesses", default=None))


@pytest.hookimpl(tryfirst=True)
def pytest_sessionstart(session):
    """Under pytest-xdist (scripts/test.sh runs ``-n auto``) the controller compiles the
    common kernels once, before its workers start, so that they load them from the cache; the
    rest (penalty, implicit integrators, the batch engine) compile in the first worker that
    needs them, while the other worker runs tests."""
    config = session.config
    if getattr(config, "workerinput", None) is None and _parallel(config):
        _warm_core(parallel=True)


@pytest.fixture(scope="session", autouse=True)
def compiled_kernels(request):
    if getattr(request.config, "workerinput", None) is not None:
        _warm_core()                     # a worker: load the common kernels from the cache
        return
    from spatialmbd.cli import main
    assert main(["warmup", "--quiet"]) == 0
