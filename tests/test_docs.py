"""The documentation: the reference builds (a broken reference fails), the worked examples of
the pages run, and nothing user-visible points outside the repository."""
import contextlib
import io
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
#: pages whose Python examples are run here (sweeps.md: tests/sweep/test_sweep.py;
#: architecture.md holds the template of a package module, relative imports and all)
RUN_PAGES = ("getting-started.md", "outputs.md", "kinematics.md", "dynamics.md", "contact.md",
             "couplers.md", "sliding-joints.md", "rolling.md", "joint-limits-friction.md",
             "actuators.md", "fmi.md", "design.md", "analyses.md", "integrators.md",
             "reliability.md", "import.md", "model-file.md", "viewer.md")


def _mkdocs(config: Path, site: Path):
    pytest.importorskip("mkdocs")
    pytest.importorskip("mkdocstrings")
    return subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "-q",
                           "-f", str(config), "-d", str(site)],
                          cwd=config.parent, capture_output=True, text=True, timeout=120)


def test_reference_documentation_builds(tmp_path):
    out = _mkdocs(ROOT / "mkdocs.yml", tmp_path / "site")
    assert out.returncode == 0, out.stderr + out.stdout
    api = (tmp_path / "site" / "api" / "index.html").read_text()
    # the API page holds the docstrings themselves, not just headings
    for text in ("Forward dynamics of", "One output request", "Write", "A new ModelBuilder"):
        assert text in api, text
    for page in ("getting-started", "kinematics", "dynamics", "outputs", "model-file",
                 "errata"):
        assert (tmp_path / "site" / page / "index.html").exists(), page


def test_a_broken_reference_fails_the_build(tmp_path):
    """The same configuration on a page naming an object that does not exist."""
    docs = tmp_path / "docs"
    docs.mkdir()
    (docs / "index.md").write_text("# API\n\n::: spatialmbd.simulate.no_such_function\n")
    config = (ROOT / "mkdocs.yml").read_text()
    config = re.sub(r"(?ms)^nav:.*?^(?=theme:)", "nav:\n  - API: index.md\n", config)
    config = config.replace("paths: [src]", f"paths: [{ROOT / 'src'}]")
    (tmp_path / "mkdocs.yml").write_text(config)
    out = _mkdocs(tmp_path / "mkdocs.yml", tmp_path / "site")
    assert out.returncode != 0
    assert "no_such_function" in out.stderr + out.stdout


def _python_blocks(page: str) -> list:
    return [code for code, _ in _examples(page)]


def _examples(page: str) -> list:
    """(code, printed) of each Python block of a page; printed: the text block right after it
    (what the block prints, as shown on the page), or None."""
    text = (DOCS / page).read_text()
    return [(m.group(1), m.group(2)) for m in re.finditer(
        r"```python\n(.*?)```[ \t]*\n(?:[ \t]*\n)?(?:```(?:text)?\n(.*?)```)?", text, re.S)]


_NUMBER = re.compile(r"[-+]?(?:\d+\.\d*|\.\d+|\d+)(?:[eE][-+]?\d+)?")
_TOKEN = re.compile(r"\.\.\.|" + _NUMBER.pattern + r"|[A-Za-z_]+|\S")


def _shown_unit(text: str) -> float:
    """Half a unit in the last digit of a number as printed: '0.0199853' -> 5e-8,
    '4.72e-07' -> 5e-10, '73' -> 0.5."""
    mantissa, _, exponent = text.lower().partition("e")
    decimals = len(mantissa.split(".")[1]) if "." in mantissa else 0
    return 0.5 * 10.0 ** (int(exponent or 0) - decimals)


def printed_matches(shown: str, printed: str) -> str:
    """'' if ``printed`` is ``shown`` with every number equal to the digits shown (the printed
    value rounds to the shown one: |printed - shown| <= half a unit in the shown last digit),
    else the first difference. Words and signs must be equal; '...' on the page stands for
    anything (wall times, addresses), up to the next token shown."""
    want, got = _TOKEN.findall(shown), _TOKEN.findall(printed)
    problem = _match(want, 0, got, 0)
    return "" if problem is None else problem


def _match(want, i, got, j):
    """None if want[i:] matches got[j:], else the first difference (an ellipsis tries every
    extent, shortest first)."""
    while i < len(want):
        if want[i] == "...":
            if i + 1 == len(want):
                return None
            first = None
            for jj in range(j, len(got) + 1):
                problem = _match(want, i + 1, got, jj)
                if problem is None:
                    return None
                first = first or problem
            return first
        if j >= len(got):
            return f"the page shows {want[i]!r} (token {i}), nothing more was printed"
        if not _same(want[i], got[j]):
            return f"the page shows {want[i]!r} (token {i}), the example printed {got[j]!r}"
        i, j = i + 1, j + 1
    if j < len(got):
        return f"the example printed more than the page shows: {' '.join(got[j:j + 8])!r}"
    return None


def _same(shown: str, printed: str) -> bool:
    if _NUMBER.fullmatch(shown) and _NUMBER.fullmatch(printed):
        # the digits shown, and no more: a printed value with fewer digits must equal it
        return abs(float(printed) - float(shown)) <= _shown_unit(shown) * (1 + 1e-9) and \
            _shown_unit(printed) <= _shown_unit(shown) * (1 + 1e-9)
    return shown == printed


def test_printed_values_are_compared_to_the_digits_shown():
    assert printed_matches("x = 0.0199853 m", "x = 0.019985312 m") == ""
    assert "0.0199853" in printed_matches("x = 0.0199853 m", "x = 0.0199861 m")
    assert printed_matches("4.72e-07 J", "4.71909e-07 J") == ""
    assert printed_matches("4.72e-07 J", "4.7e-07 J") != ""           # fewer digits than shown
    assert printed_matches("wall time ... s, 3 steps", "wall time 0.2 s, 3 steps") == ""
    assert printed_matches("[0.3 0.5]", "[0.3 0.5 0.7]") != ""
    assert printed_matches("status: success", "status: failed") != ""


def test_worked_examples_of_the_pages_run(tmp_path, monkeypatch):
    # they write files: run in a folder of their own, with the examples they read at hand
    (tmp_path / "examples").symlink_to(ROOT / "examples")
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(sys, "path", list(sys.path))     # pages add example folders
    spaces = {}
    for page in RUN_PAGES:
        examples = _examples(page)
        assert examples, page
        namespace = spaces[page] = {"__name__": "__docs__"}
        for k, (code, shown) in enumerate(examples):
            out = io.StringIO()
            try:
                with contextlib.redirect_stdout(out):
                    exec(compile(code, f"{page}[{k}]", "exec"), namespace)
            except ImportError as exc:                 # optional extras (xarray)
                if "xarray" not in str(exc):
                    raise
                continue
            # what an example prints is shown on its page, right after it, and equal to the
            # digits shown
            assert shown is not None or not out.getvalue().strip(), \
                f"{page}[{k}] prints, and the page does not show it:\n{out.getvalue()}"
            if shown is not None:
                problem = printed_matches(shown, out.getvalue())
                assert not problem, f"{page}[{k}]: {problem}\nprinted:\n{out.getvalue()}"
    # values the pages state: the pendulum swings to the other horizontal (energy conserved)
    assert spaces["getting-started.md"]["out"]["pivot.angle"].min() == \
        pytest.approx(-np.pi, abs=0.02)
    assert spaces["getting-started.md"]["units"]["pivot.angle"] == "rad"
    assert spaces["outputs.md"]["out"].attrs["units"]["spiral.torque"] == "N m"
    assert spaces["contact.md"]["ratio"] == pytest.approx(0.7885, abs=2e-3)   # with gravity
    assert spaces["contact.md"]["error"] < 1e-6
    door = spaces["joint-limits-friction.md"]           # touch: 1.4 = 2 t - (T / I) t^2 / 2
    a = 0.3 / (1.35 + 20 * 0.45 ** 2)
    assert door["touch"] == pytest.approx((2 - np.sqrt(4 - 2 * a * 1.4)) / a, abs=1e-9)
    assert door["energy_error"] < 1e-6
    fmi = spaces["fmi.md"]                    # the FMU's run = the held-input simulation
    assert fmi["problems"] == [] and fmi["difference"] < 1e-8
    assert fmi["loop_difference"] <= 1e-12 and fmi["final_angle"] == pytest.approx(0.445,
                                                                                   abs=1e-3)
    act = spaces["actuators.md"]                       # the PD step response, closed form
    assert act["step_error"] < 1e-9 and act["energy_error"] < 1e-9
    assert act["final_angle"] == pytest.approx(0.5, abs=0.01)   # the sampled controller
    lean = spaces["rolling.md"]["lean"]                # the bicycle pushed at 4.6 m/s recovers
    assert np.degrees(lean.max()) == pytest.approx(6.6, abs=0.05)
    assert np.abs(lean[-100:]).max() < 0.25 * lean.max()


USER_VISIBLE = ["src", "docs", "examples", "README.md", "mkdocs.yml", "pyproject.toml"]


def test_nothing_user_visible_refers_outside_the_repository():
    pattern = re.compile(r"\.\./shared|/work/shared|shared/(seed|benchdata)")
    bad = []
    for entry in USER_VISIBLE:
        path = ROOT / entry
        files = [path] if path.is_file() else [p for p in path.rglob("*") if p.is_file()]
        for f in files:
            if f.suffix in (".png", ".pyc", ".ico", ".woff", ".woff2") or "__pycache__" in f.parts:
                continue
            try:
                text = f.read_text()
            except UnicodeDecodeError:
                continue
            for n, line in enumerate(text.splitlines(), 1):
                if pattern.search(line):
                    bad.append(f"{f.relative_to(ROOT)}:{n}: {line.strip()[:100]}")
    assert not bad, "\n".join(bad)


def test_outputs_example_script_runs(tmp_path, capsys):
    import runpy
    script = runpy.run_path(str(ROOT / "examples" / "outputs_slider_crank.py"))
    stroke_error, work, change = script["main"](tmp_path)
    assert stroke_error < 1e-9                                   # m, against the closed form
    assert np.abs(work - change).max() < 1e-4 * np.abs(change).max()
    assert (tmp_path / "slider_crank_outputs.png").stat().st_size > 1000
