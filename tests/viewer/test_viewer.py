"""Tests of the offline HTML animation viewer (spatialmbd.viewer).

The browser tests drive a real headless Chromium through the DevTools protocol over
``--remote-debugging-pipe`` (fds 3/4, NUL-separated JSON), standard library only.  Without
``/usr/bin/chromium`` they are skipped, unless SPATIALMBD_REQUIRE_BROWSER=1, then they fail.
"""
from __future__ import annotations

import base64
import fcntl
import io
import json
import math
import os
import re
import select
import shutil
import signal
import subprocess
import sys
import tempfile
import time

import numpy as np
import pytest

from spatialmbd.viewer import (animation_html, decode_float32, default_shapes,
                               write_animation_html)

CHROMIUM = os.environ.get("SPATIALMBD_CHROMIUM", "/usr/bin/chromium")
SHOT_W, SHOT_H = 800, 600


# ----------------------------------------------------------------------------------------------
# scenes
# ----------------------------------------------------------------------------------------------
def _p_about_y(phi):
    """Euler parameters of a rotation by phi about the global y axis."""
    phi = np.asarray(phi, dtype=float)
    z = np.zeros_like(phi)
    return np.stack([np.cos(phi / 2), z, np.sin(phi / 2), z], axis=-1)


def double_pendulum_scene(n_frames=201, t_end=2.0):
    """Two box links hanging from a revolute joint at the origin (gravity -z), analytic motion.

    Each link lies along its body x axis; a rotation by phi about y maps x to
    (cos phi, 0, -sin phi), so phi = pi/2 hangs straight down.
    """
    length = 1.0
    t = np.linspace(0.0, t_end, n_frames)
    phi1 = np.pi / 2 + 0.9 * np.sin(2.2 * t)
    phi2 = np.pi / 2 + 1.2 * np.sin(2.2 * t + 1.0)
    x1 = np.stack([np.cos(phi1), 0 * t, -np.sin(phi1)], axis=1)
    x2 = np.stack([np.cos(phi2), 0 * t, -np.sin(phi2)], axis=1)
    r1 = 0.5 * length * x1
    r2 = length * x1 + 0.5 * length * x2
    box = {"type": "box", "size": [length, 0.08, 0.12], "center": [0, 0, 0]}
    pin = {"type": "cylinder", "radius": 0.05, "length": 0.16, "center": [-0.5, 0, 0],
           "axis": [0, 1, 0]}
    return {
        "t": t,
        "bodies": [
            {"name": "link1", "r": r1, "p": _p_about_y(phi1), "shapes": [box, pin],
             "color": "#4e79a7"},
            {"name": "link2", "r": r2, "p": _p_about_y(phi2),
             "shapes": [box, pin, {"type": "sphere", "radius": 0.09, "center": [0.5, 0, 0]}],
             "color": "#f28e2b"},
        ],
        "joints": [
            {"name": "pivot", "type": "revolute", "body": -1, "point_local": [0, 0, 0]},
            {"name": "elbow", "type": "revolute", "body": 0, "point_local": [0.5, 0, 0]},
        ],
        "ground": [{"type": "box", "size": [0.3, 0.3, 0.05], "center": [0, 0, 0.1]}],
        "gravity": [0, 0, -9.81],
    }


def chain_scene(n_frames=500, n_bodies=5, seed=0):
    """A generic tumbling chain: n_bodies bodies with random-ish smooth motion."""
    rng = np.random.default_rng(seed)
    t = np.linspace(0.0, 5.0, n_frames)
    bodies = []
    for i in range(n_bodies):
        w = rng.normal(size=3)
        phi = 0.7 * t * np.linalg.norm(w)
        u = w / np.linalg.norm(w)
        p = np.concatenate([np.cos(phi / 2)[:, None], np.sin(phi / 2)[:, None] * u], axis=1)
        r = np.stack([i + 0.3 * np.sin(t + i), 0.2 * np.cos(2 * t), 0.1 * t], axis=1)
        bodies.append({"name": f"b{i}", "r": r, "p": p,
                       "shapes": default_shapes(2.0, [0.02, 0.05, 0.06])})
    joints = [{"name": f"j{i}", "type": "spherical", "body": i, "point_local": [0.2, 0, 0]}
              for i in range(n_bodies)]
    return {"t": t, "bodies": bodies, "joints": joints, "gravity": [0, 0, -9.81]}


def _embedded_scene(html_text):
    m = re.search(r'<script type="application/json" id="spatialmbd-scene">(.*?)</script>',
                  html_text, re.S)
    assert m, "embedded scene JSON not found"
    return json.loads(m.group(1))


# ----------------------------------------------------------------------------------------------
# pure-Python tests
# ----------------------------------------------------------------------------------------------
def _body_q(body):
    """(n_samples, 7) r then p of an embedded body (base64 float32)."""
    return decode_float32(body["q"]).reshape(-1, 7)


@pytest.mark.parametrize("renderer", ["auto", "canvas"])
def test_html_is_offline(renderer):
    text = animation_html(double_pendulum_scene(), title="offline check", renderer=renderer)
    # the XHTML namespace in three.js (document.createElementNS) is a name, not a resource
    text_without_ns = text.replace("http://www.w3.org/1999/xhtml", "")
    assert "http://" not in text_without_ns and "https://" not in text_without_ns
    assert not re.search(r"<script[^>]*\bsrc\s*=", text, re.I), "external script"
    assert not re.search(r"<link[^>]*rel=\"?stylesheet", text, re.I), "external stylesheet"
    assert not re.search(r"@import|url\(\s*['\"]?(?!data:)", text), "external CSS resource"
    assert not re.search(r"\b(fetch|XMLHttpRequest|importScripts)\s*\(", text)
    assert "{{" not in text  # every placeholder substituted
    assert "<title>offline check</title>" in text
    assert ("var THREE=" in text) == (renderer == "auto")
    if renderer == "auto":  # three.js's MIT notice travels with the embedded bundle
        assert "Permission is hereby granted, free of charge" in text


def test_three_bundle_is_package_data():
    from importlib import resources
    viewer = resources.files("spatialmbd.viewer")
    bundle = viewer.joinpath("three.min.js").read_text(encoding="utf-8")
    notice = viewer.joinpath("THREE_LICENSE").read_text(encoding="utf-8")
    assert bundle.startswith("/*! three.js ") and "THREE=" in bundle
    assert "</script" not in bundle.lower()
    assert "MIT License" in notice and "three.js authors" in notice


def test_embedded_data_round_trip():
    scene = double_pendulum_scene(n_frames=51)
    data = _embedded_scene(animation_html(scene))
    t = np.asarray(scene["t"])
    np.testing.assert_allclose(data["t"], t, rtol=1e-5, atol=1e-12)
    assert len(data["bodies"]) == 2
    for got, want in zip(data["bodies"], scene["bodies"]):
        assert got["name"] == want["name"] and got["color"] == want["color"]
        q = _body_q(got)  # float32: 2^-24 relative rounding
        np.testing.assert_allclose(q[:, :3], want["r"], rtol=1e-6, atol=1e-7)
        np.testing.assert_allclose(q[:, 3:], want["p"], rtol=1e-6, atol=1e-7)
        assert [s["type"] for s in got["shapes"]] == [s["type"] for s in want["shapes"]]
    assert data["bodies"][0]["shapes"][1]["axis"] == [0, 1, 0]
    assert [j["name"] for j in data["joints"]] == ["pivot", "elbow"]
    assert data["joints"][1] == {"name": "elbow", "type": "revolute", "body": 0,
                                 "point": [0.5, 0, 0]}
    np.testing.assert_allclose(data["up"], [0, 0, 1])
    assert data["ground"][0]["type"] == "box"


def test_numbers_rounded_and_script_safe():
    scene = double_pendulum_scene(n_frames=11)
    scene["bodies"][0]["name"] = "</script><b>x</b>"
    scene["t"] = scene["t"] + 1.0 / 3.0
    text = animation_html(scene, title="a <b>bold</b> {{SCENE_JSON}} title")
    assert text.count("</script>") == 4  # only the real closing tags (scene and 3 scripts)
    assert "a &lt;b&gt;bold&lt;/b&gt; {{SCENE_JSON}} title" in text
    data = _embedded_scene(text)
    assert data["bodies"][0]["name"] == "</script><b>x</b>"
    assert data["title"] == "a <b>bold</b> {{SCENE_JSON}} title"
    for x in data["t"]:
        assert len(repr(x).replace("-", "").replace(".", "").lstrip("0")) <= 6


def test_write_animation_html_and_size(tmp_path):
    path = write_animation_html(tmp_path / "sub" / "chain.html", chain_scene(500, 5),
                                renderer="canvas")
    assert path == tmp_path / "sub" / "chain.html" and path.is_file()
    size = path.stat().st_size
    # 500 frames x 5 bodies x 7 float32 in base64 (93 kB), times at 6 significant digits
    # (~6 kB), plus ~45 kB of viewer
    assert size < 160_000, size
    data = _embedded_scene(path.read_text(encoding="utf-8"))
    assert len(data["t"]) == 500 and _body_q(data["bodies"][4]).shape == (500, 7)
    # the WebGL page adds the three.js bundle and its back end, nothing per frame
    from importlib import resources
    bundle = len(resources.files("spatialmbd.viewer").joinpath("three.min.js").read_bytes())
    auto = write_animation_html(tmp_path / "auto.html", chain_scene(500, 5))
    assert 0 < auto.stat().st_size - size - bundle < 20_000


def test_static_body_and_defaults():
    scene = {"t": [0.0, 1.0], "bodies": [{"name": "fixed", "r": [1, 2, 3], "p": [1, 0, 0, 0],
                                          "shapes": {"type": "sphere", "radius": 0.1}}]}
    data = _embedded_scene(animation_html(scene))
    b = data["bodies"][0]
    assert _body_q(b).tolist() == [[1, 2, 3, 1, 0, 0, 0]]
    assert b["color"].startswith("#") and b["shapes"][0]["center"] == [0, 0, 0]
    assert data["up"] == [0, 0, 1] and data["joints"] == [] and data["ground"] == []


@pytest.mark.parametrize("mutate, match", [
    (lambda s: s.update(t=[[0.0, 1.0]]), "1-D"),
    (lambda s: s.update(t=s["t"][::-1]), "non-decreasing"),
    (lambda s: s["bodies"][0].update(r=np.zeros((3, 3))), r"\['r'\]"),
    (lambda s: s["bodies"][0].update(p=np.full((201, 4), np.nan)), "non-finite"),
    (lambda s: s["bodies"][0]["shapes"].append({"type": "cone"}), "unknown shape"),
    (lambda s: s["bodies"][0]["shapes"].append({"type": "box", "size": [1, 0, 1]}), "size"),
    (lambda s: s["bodies"][0].update(color="red"), "colour"),
    (lambda s: s["joints"].append({"name": "j", "body": 2}), "body"),
    (lambda s: s.update(springs=[{"kind": "rope"}]), "unknown kind"),
    (lambda s: s.update(springs=[{"body_i": 5}]), "body_i"),
    (lambda s: s.update(arrows=[{"vectors": np.zeros((3, 3))}]), r"\['vectors'\]"),
    (lambda s: s.update(points=[{"positions": np.full((201, 3), np.inf)}]), "non-finite"),
])
def test_scene_validation(mutate, match):
    scene = double_pendulum_scene()
    mutate(scene)
    with pytest.raises(ValueError, match=match):
        animation_html(scene)


def test_springs_arrows_points_embedded():
    scene = double_pendulum_scene(n_frames=21)
    force = np.stack([np.zeros(21), np.zeros(21), np.linspace(1, 3, 21)], axis=1)
    scene["springs"] = [{"name": "k", "kind": "spring_damper", "body_i": -1,
                         "point_i": [1, 0, 0], "body_j": 1, "point_j": [0.5, 0, 0],
                         "turns": 6}]
    scene["arrows"] = [{"name": "F", "kind": "reaction", "body": 0, "point_local": [-0.5, 0, 0],
                        "vectors": force}]
    scene["points"] = [{"name": "c", "positions": force, "radius": 0.02}]
    data = _embedded_scene(animation_html(scene))
    assert data["springs"] == [{"name": "k", "kind": "spring_damper", "body_i": -1,
                                "point_i": [1, 0, 0], "body_j": 1, "point_j": [0.5, 0, 0],
                                "turns": 6}]
    np.testing.assert_allclose(decode_float32(data["arrows"][0]["vectors"]).reshape(-1, 3),
                               force, rtol=1e-7)
    assert data["arrows"][0]["point"] == [-0.5, 0, 0] and data["arrows"][0]["body"] == 0
    np.testing.assert_allclose(decode_float32(data["points"][0]["positions"]).reshape(-1, 3),
                               force, rtol=1e-7)


def test_capsule_drawn_as_cylinder_and_two_spheres():
    scene = {"t": [0.0], "bodies": [{"name": "c", "r": [0, 0, 0], "p": [1, 0, 0, 0], "shapes": [
        {"type": "capsule", "radius": 0.1, "length": 0.6, "axis": [2, 0, 0],
         "center": [0, 1, 0], "color": "#112233"}]}]}
    shapes = _embedded_scene(animation_html(scene, renderer="canvas"))["bodies"][0]["shapes"]
    assert [s["type"] for s in shapes] == ["cylinder", "sphere", "sphere"]
    assert shapes[0]["axis"] == [1, 0, 0] and shapes[0]["length"] == 0.6
    assert [s["center"] for s in shapes[1:]] == [[-0.3, 1, 0], [0.3, 1, 0]]
    assert all(s["radius"] == 0.1 and s["color"] == "#112233" for s in shapes)


def _box_inertia(mass, size):
    lx, ly, lz = size
    return mass / 12.0 * np.array([ly**2 + lz**2, lz**2 + lx**2, lx**2 + ly**2])


@pytest.mark.parametrize("mass, size", [(2.0, (0.5, 0.2, 0.1)), (7.5, (1.0, 1.0, 1.0)),
                                        (0.3, (0.02, 1.3, 0.4))])
def test_default_shapes_matches_inertia(mass, size):
    shapes = default_shapes(mass, _box_inertia(mass, size))
    assert len(shapes) == 1 and shapes[0]["type"] == "box"
    assert shapes[0]["center"] == [0.0, 0.0, 0.0]
    np.testing.assert_allclose(shapes[0]["size"], size, rtol=1e-12)
    np.testing.assert_allclose(_box_inertia(mass, shapes[0]["size"]), _box_inertia(mass, size),
                               rtol=1e-12)
    json.dumps(shapes)  # plain JSON-serialisable floats
    # a full (rotated) inertia matrix gives the same box up to the order of the sides
    q, _ = np.linalg.qr(np.random.default_rng(1).normal(size=(3, 3)))
    inertia = q @ np.diag(_box_inertia(mass, size)) @ q.T
    np.testing.assert_allclose(sorted(default_shapes(mass, inertia)[0]["size"]), sorted(size),
                               rtol=1e-9)


def test_default_shapes_clamps_degenerate_sides():
    # thin rod: Ix = 0, Iy = Iz = m L^2 / 12 -> ly = lz = 0, clamped to 5 % of L
    m, L = 3.0, 2.0
    size = default_shapes(m, [0.0, m * L**2 / 12, m * L**2 / 12])[0]["size"]
    np.testing.assert_allclose(size, [L, 0.05 * L, 0.05 * L])
    # triangle inequality violated (Ix > Iy + Iz): that side is clamped, all stay positive
    size = default_shapes(1.0, [1.0, 0.2, 0.3])[0]["size"]
    assert min(size) > 0 and math.isclose(size[0], 0.05 * max(size))
    # point mass: a small cube
    assert default_shapes(1.0, [0, 0, 0])[0]["size"] == [0.1, 0.1, 0.1]
    with pytest.raises(ValueError):
        default_shapes(0.0, [1, 1, 1])
    with pytest.raises(ValueError):
        default_shapes(1.0, [1, -1, 1])


# ----------------------------------------------------------------------------------------------
# headless Chromium through the DevTools protocol over a pipe
# ----------------------------------------------------------------------------------------------
class BrowserError(RuntimeError):
    pass


class CDPPipe:
    """Minimal Chrome DevTools Protocol client over --remote-debugging-pipe (fd 3 in, fd 4 out)."""

    def __init__(self, executable, timeout=20.0):
        self.timeout = timeout
        self.profile = tempfile.mkdtemp(prefix="spatialmbd-chromium-")
        self.stderr = open(os.path.join(self.profile, "stderr.log"), "w+b")
        to_chrome_r, self._to_chrome = os.pipe()
        self._from_chrome, from_chrome_w = os.pipe()
        # the child's ends get numbers >= 10 so the shell redirections below cannot clobber them
        a = fcntl.fcntl(to_chrome_r, fcntl.F_DUPFD, 10)
        b = fcntl.fcntl(from_chrome_w, fcntl.F_DUPFD, 10)
        os.close(to_chrome_r)
        os.close(from_chrome_w)
        # WebGL through SwiftShader (software GL), so the WebGL renderer runs headless too
        flags = ["--headless", "--no-sandbox", "--use-angle=swiftshader",
                 "--enable-unsafe-swiftshader", "--disable-dev-shm-usage",
                 "--remote-debugging-pipe", f"--user-data-dir={self.profile}", "--no-first-run",
                 "--no-default-browser-check", "--disable-background-networking",
                 "--disable-component-update", "--disable-sync", "--disable-quic",
                 "--disable-extensions", "--mute-audio", "--hide-scrollbars",
                 f"--window-size={SHOT_W},{SHOT_H}", "about:blank"]
        # a tiny Python trampoline puts the pipe ends on fds 3 and 4, then execs Chromium
        # (dash cannot redirect fds >= 10)
        trampoline = ("import os, sys; a, b = int(sys.argv[1]), int(sys.argv[2]); "
                      "os.dup2(a, 3); os.dup2(b, 4); os.close(a); os.close(b); "
                      "os.execv(sys.argv[3], sys.argv[3:])")
        try:
            self.proc = subprocess.Popen([sys.executable, "-c", trampoline, str(a), str(b),
                                          executable, *flags],
                                         stdin=subprocess.DEVNULL, stdout=self.stderr,
                                         stderr=self.stderr, pass_fds=(a, b),
                                         start_new_session=True)
        finally:
            os.close(a)
            os.close(b)
        self._buf = b""
        self._next_id = 0
        self.events = []
        self._targets = {}

    # -- transport -----------------------------------------------------------------------------
    def _read_message(self, deadline):
        while b"\0" not in self._buf:
            remaining = deadline - time.monotonic()
            if remaining <= 0:
                raise BrowserError("timed out waiting for Chromium" + self._log_tail())
            ready, _, _ = select.select([self._from_chrome], [], [], remaining)
            if not ready:
                continue
            chunk = os.read(self._from_chrome, 1 << 20)
            if not chunk:
                raise BrowserError("Chromium closed the DevTools pipe" + self._log_tail())
            self._buf += chunk
        msg, self._buf = self._buf.split(b"\0", 1)
        return json.loads(msg)

    def call(self, method, params=None, session=None, timeout=None):
        self._next_id += 1
        msg = {"id": self._next_id, "method": method, "params": params or {}}
        if session:
            msg["sessionId"] = session
        os.write(self._to_chrome, json.dumps(msg).encode() + b"\0")
        deadline = time.monotonic() + (timeout or self.timeout)
        while True:
            reply = self._read_message(deadline)
            if reply.get("id") == self._next_id:
                if "error" in reply:
                    raise BrowserError(f"{method}: {reply['error']}")
                return reply.get("result", {})
            self.events.append(reply)

    def wait_event(self, method, session, timeout=None):
        deadline = time.monotonic() + (timeout or self.timeout)
        seen = 0
        while True:
            for ev in self.events[seen:]:
                if ev.get("method") == method and ev.get("sessionId") == session:
                    return ev
            seen = len(self.events)
            self.events.append(self._read_message(deadline))

    def _log_tail(self):
        try:
            self.stderr.flush()
            self.stderr.seek(0)
            tail = self.stderr.read()[-2000:].decode(errors="replace")
        except (OSError, ValueError):
            tail = ""
        return f"\n--- chromium stderr (tail) ---\n{tail}" if tail else ""

    # -- pages ---------------------------------------------------------------------------------
    def open_page(self, url, init_script=None):
        """Open ``url`` in a new tab (domains enabled first, so early errors are seen);
        ``init_script`` runs in the page before any of its own scripts."""
        target = self.call("Target.createTarget", {"url": "about:blank"})["targetId"]
        session = self.call("Target.attachToTarget",
                            {"targetId": target, "flatten": True})["sessionId"]
        self._targets[session] = target
        for domain in ("Page", "Runtime", "Log"):
            self.call(f"{domain}.enable", session=session)
        if init_script:
            self.call("Page.addScriptToEvaluateOnNewDocument", {"source": init_script},
                      session=session)
        self.call("Emulation.setDeviceMetricsOverride",
                  {"width": SHOT_W, "height": SHOT_H, "deviceScaleFactor": 1, "mobile": False},
                  session=session)
        n_before = len(self.events)
        self.call("Page.navigate", {"url": url}, session=session)
        deadline = time.monotonic() + self.timeout
        while not any(ev.get("method") == "Page.loadEventFired" and ev.get("sessionId") == session
                      for ev in self.events[n_before:]):
            self.events.append(self._read_message(deadline))
        return session

    def close_page(self, session):
        target = self._targets.pop(session, None)
        if target:
            self.call("Target.closeTarget", {"targetId": target})

    def evaluate(self, session, expression):
        res = self.call("Runtime.evaluate", {"expression": expression, "returnByValue": True,
                                             "awaitPromise": True}, session=session)
        if "exceptionDetails" in res:
            raise BrowserError(f"{expression!r} raised {res['exceptionDetails']}")
        return res["result"].get("value")

    def screenshot(self, session):
        data = self.call("Page.captureScreenshot", {"format": "png"}, session=session)["data"]
        return base64.b64decode(data)

    def errors(self, session):
        """JavaScript exceptions, console.error/assert calls and error log entries of a page."""
        out = []
        for ev in self.events:
            if ev.get("sessionId") != session:
                continue
            method, params = ev.get("method"), ev.get("params", {})
            if method == "Runtime.exceptionThrown":
                d = params.get("exceptionDetails", {})
                out.append(d.get("exception", {}).get("description") or d.get("text"))
            elif method == "Runtime.consoleAPICalled" and params.get("type") in ("error",
                                                                                  "assert"):
                out.append(" ".join(str(a.get("value", a.get("description")))
                                    for a in params.get("args", [])))
            elif method == "Log.entryAdded" and params.get("entry", {}).get("level") == "error":
                out.append(params["entry"].get("text"))
        return out

    def close(self):
        try:
            if self.proc.poll() is None:
                try:
                    self.call("Browser.close", timeout=5)
                except (BrowserError, OSError):
                    pass
                try:
                    self.proc.wait(timeout=5)
                except subprocess.TimeoutExpired:
                    os.killpg(self.proc.pid, signal.SIGKILL)  # our own session only
                    self.proc.wait(timeout=5)
        finally:
            for fd in (self._to_chrome, self._from_chrome):
                try:
                    os.close(fd)
                except OSError:
                    pass
            self.stderr.close()
            shutil.rmtree(self.profile, ignore_errors=True)


def _require_browser():
    if os.path.isfile(CHROMIUM) and os.access(CHROMIUM, os.X_OK):
        return CHROMIUM
    reason = (f"headless Chromium not found at {CHROMIUM} "
              "(install with: apt-get install -y chromium)")
    if os.environ.get("SPATIALMBD_REQUIRE_BROWSER") == "1":
        pytest.fail(reason + "; SPATIALMBD_REQUIRE_BROWSER=1 makes this a failure")
    pytest.skip(reason)


@pytest.fixture(scope="module")
def browser():
    client = CDPPipe(_require_browser())
    try:
        client.call("Browser.getVersion")
        yield client
    finally:
        client.close()


@pytest.fixture(scope="module")
def pendulum_page(tmp_path_factory):
    path = tmp_path_factory.mktemp("viewer") / "pendulum.html"
    return write_animation_html(path, double_pendulum_scene(), title="double pendulum")


def _load(browser, path, fragment, init_script=None):
    session = browser.open_page(path.resolve().as_uri() + fragment, init_script)
    deadline = time.monotonic() + 10
    while not browser.evaluate(session, "!!(window.spatialmbdViewer && "
                                        "window.spatialmbdViewer.ready)"):
        assert time.monotonic() < deadline, f"viewer not ready; errors: {browser.errors(session)}"
        time.sleep(0.05)
    return session


def _image(png):
    from PIL import Image  # pillow comes with matplotlib, a dependency of spatialmbd
    return np.asarray(Image.open(io.BytesIO(png)).convert("RGB"), dtype=np.int16)


def _n_colours(img):
    flat = img.reshape(-1, 3).astype(np.int32)
    return len(np.unique((flat[:, 0] << 16) | (flat[:, 1] << 8) | flat[:, 2]))


@pytest.mark.browser
def test_browser_loads_without_errors_and_honours_hash(browser, pendulum_page):
    session = _load(browser, pendulum_page, "#t=0.5")
    assert browser.evaluate(session, "document.title") == "double pendulum"
    state = browser.evaluate(session, "({t: spatialmbdViewer.getTime(), n: spatialmbdViewer."
                                      "nFrames, playing: spatialmbdViewer.isPlaying(), "
                                      "errors: window.spatialmbdViewerErrors.length})")
    assert state == {"t": 0.5, "n": 201, "playing": False, "errors": 0}
    assert browser.evaluate(session, "spatialmbdViewer.setTime(1.25), "
                                     "spatialmbdViewer.getTime()") == 1.25
    assert browser.evaluate(session, "spatialmbdViewer.setTime(99), "
                                     "spatialmbdViewer.getTime()") == 2.0
    assert browser.evaluate(session, "document.getElementById('time-label').textContent") == \
        "t = 2.000 s / 2.000 s"
    # real-time playback advances the time
    browser.evaluate(session, "spatialmbdViewer.setTime(0), spatialmbdViewer.setSpeed(2), "
                              "spatialmbdViewer.play()")
    deadline = time.monotonic() + 5
    while (t := browser.evaluate(session, "spatialmbdViewer.getTime()")) == 0.0:
        assert time.monotonic() < deadline, "playback does not advance"
        time.sleep(0.05)
    assert 0.0 < t <= 2.0
    assert browser.evaluate(session, "spatialmbdViewer.isPlaying()") is True
    browser.evaluate(session, "spatialmbdViewer.pause()")
    assert browser.errors(session) == []
    browser.close_page(session)


@pytest.mark.browser
def test_browser_screenshots_show_motion(browser, pendulum_page):
    shots = {}
    for frag in ("#t=0.0", "#t=1.0"):
        session = _load(browser, pendulum_page, frag)
        assert browser.evaluate(session, "spatialmbdViewer.isPlaying()") is False
        shots[frag] = browser.screenshot(session)
        assert browser.errors(session) == []
        browser.close_page(session)
    out_dir = os.environ.get("SPATIALMBD_SCREENSHOT_DIR")
    if out_dir:  # keep the pictures for a human look
        os.makedirs(out_dir, exist_ok=True)
        for frag, png in shots.items():
            with open(os.path.join(out_dir, f"pendulum_{frag[3:]}.png"), "wb") as fh:
                fh.write(png)
    a, b = _image(shots["#t=0.0"]), _image(shots["#t=1.0"])
    assert a.shape[:2] == (SHOT_H, SHOT_W)
    for img in (a, b):  # not blank: many colours, strong contrast, coloured bodies
        flat = img.reshape(-1, 3)
        assert _n_colours(img) > 200
        assert flat.std(axis=0).max() > 20
        saturation = flat.max(axis=1) - flat.min(axis=1)
        assert (saturation > 80).sum() > 500, "no coloured body pixels"
    changed = np.abs(a - b).max(axis=2) > 30
    assert changed.sum() > 1000, "the mechanism does not move between t=0 and t=1"


@pytest.mark.browser
def test_browser_camera_interaction(browser, pendulum_page):
    session = _load(browser, pendulum_page, "#t=0.3")
    before = browser.screenshot(session)
    # orbit by a mouse drag, then zoom by the wheel: the picture changes, no errors
    for typ, x in (("mousePressed", 300), ("mouseMoved", 360), ("mouseReleased", 360)):
        browser.call("Input.dispatchMouseEvent", {"type": typ, "x": x, "y": 250,
                                                  "button": "left", "buttons": 1,
                                                  "clickCount": 1}, session=session)
    browser.call("Input.dispatchMouseEvent", {"type": "mouseWheel", "x": 400, "y": 300,
                                              "deltaX": 0, "deltaY": -300}, session=session)
    browser.evaluate(session, "new Promise(r => requestAnimationFrame(() => "
                              "requestAnimationFrame(r)))")
    after = browser.screenshot(session)
    assert (np.abs(_image(before) - _image(after)).max(axis=2) > 30).sum() > 1000
    browser.evaluate(session, "document.getElementById('btn-fit').click()")
    assert browser.errors(session) == []
    browser.close_page(session)


@pytest.mark.browser
def test_browser_degenerate_scenes(browser, tmp_path):
    """One frame, y-up gravity, a body without shapes, ground shapes only: no errors."""
    scenes = {
        "single": {"t": [0.0], "gravity": [0, -9.81, 0],
                   "bodies": [{"name": "still", "r": [[0.2, 0.1, 0]], "p": [[1, 0, 0, 0]],
                               "shapes": [{"type": "cylinder", "radius": 0.05, "length": 0.4,
                                           "axis": [1, 0, 0]}]},
                              {"name": "bare", "r": [0, 0.5, 0], "p": [0, 0, 0, 1]}],
                   "joints": [{"name": "g", "type": "fixed", "body": -1,
                               "point_local": [0, 0, 0]}]},
        "empty": {"t": np.linspace(0, 1, 5), "bodies": [],
                  "ground": [{"type": "sphere", "radius": 0.3, "center": [1, 1, 1]}]},
    }
    for name, scene in scenes.items():
        path = write_animation_html(tmp_path / f"{name}.html", scene, title=name)
        session = _load(browser, path, "")
        assert browser.evaluate(session, "document.title") == name
        browser.evaluate(session, "spatialmbdViewer.setTime(0.5)")
        browser.evaluate(session, "spatialmbdViewer.fit()")
        assert _n_colours(_image(browser.screenshot(session))) > 50
        assert browser.errors(session) == [], name
        browser.close_page(session)


# ----------------------------------------------------------------------------------------------
# WebGL renderer (SwiftShader) and the Canvas fallback: the screenshot must show the scene
# ----------------------------------------------------------------------------------------------
# Make WebGL unavailable before any page script runs (as in a browser without GPU support).
_NO_WEBGL = """(function () {
  var orig = HTMLCanvasElement.prototype.getContext;
  HTMLCanvasElement.prototype.getContext = function (kind) {
    if (/webgl/i.test(String(kind))) { return null; }
    return orig.apply(this, arguments);
  };
})();"""

_BODY_HUES = {"#4e79a7": (2, 1, 0), "#f28e2b": (0, 1, 2)}  # channel order, most to least


def _body_pixels(img, xy, colour, half=9):
    """Pixels near screen point ``xy`` with the body colour's channel order and saturation."""
    x, y = int(round(xy[0])), int(round(xy[1]))
    patch = img[max(0, y - half):y + half + 1, max(0, x - half):x + half + 1].reshape(-1, 3)
    hi, mid, lo = _BODY_HUES[colour]
    ok = (patch[:, hi] >= patch[:, mid]) & (patch[:, mid] >= patch[:, lo]) & (
        patch[:, hi] - patch[:, lo] > 40)
    return int(ok.sum())


def _check_scene_shown(browser, session, expected_renderer, name):
    assert browser.evaluate(session, "spatialmbdViewer.renderer()") == expected_renderer, \
        browser.evaluate(session, "spatialmbdViewer.fallbackReason()")
    img = _image(browser.screenshot(session))
    out_dir = os.environ.get("SPATIALMBD_SCREENSHOT_DIR")
    if out_dir:
        os.makedirs(out_dir, exist_ok=True)
        from PIL import Image
        Image.fromarray(img.astype(np.uint8)).save(os.path.join(out_dir, name + ".png"))
    background = img[5:20, 300:340].reshape(-1, 3).mean(axis=0)   # above the scene
    assert np.all(background > 200), f"{name}: page background {background} (blank/black?)"
    # each link's colour is at its centre of mass as projected by the viewer's camera
    for k, colour in enumerate(("#4e79a7", "#f28e2b")):
        xy = browser.evaluate(session, f"spatialmbdViewer.screenPosition({k}, [0, 0, 0])")
        assert xy is not None and 0 <= xy[0] < SHOT_W and 0 <= xy[1] < SHOT_H - 50
        n = _body_pixels(img, xy, colour)
        assert n > 150, f"{name}: body {k} ({colour}) not drawn at {xy}: {n} of 361 pixels"
    # and not everywhere: far from the bodies (a corner of the floor) is not body-coloured
    assert _body_pixels(img, (SHOT_W - 60, SHOT_H - 120), "#4e79a7") < 20
    return img


@pytest.mark.browser
def test_browser_webgl_renderer_draws_the_scene(browser, tmp_path):
    scene = double_pendulum_scene()
    scene["springs"] = [{"name": "k", "kind": "spring", "body_i": -1, "point_i": [0.8, 0, 0.3],
                         "body_j": 1, "point_j": [0.5, 0, 0], "color": "#222222"}]
    scene["arrows"] = [{"name": "R", "kind": "reaction", "body": -1, "point_local": [0, 0, 0],
                        "vectors": np.tile([0.0, 0.0, 30.0], (201, 1)), "color": "#d62728"}]
    path = write_animation_html(tmp_path / "gl.html", scene, title="webgl")
    session = _load(browser, path, "#t=0.5")
    img = _check_scene_shown(browser, session, "webgl", "webgl_pendulum")
    # the spring: dark pixels along the line from its ground point to its body point
    a = browser.evaluate(session, "spatialmbdViewer.screenPosition(-1, [0.8, 0, 0.3])")
    b = browser.evaluate(session, "spatialmbdViewer.screenPosition(1, [0.5, 0, 0])")
    dark = 0
    for s in np.linspace(0.2, 0.8, 7):
        x, y = (1 - s) * np.asarray(a) + s * np.asarray(b)
        patch = img[int(y) - 12:int(y) + 13, int(x) - 12:int(x) + 13].reshape(-1, 3)
        dark += int((patch.max(axis=1) < 90).any())
    assert dark >= 5, f"spring helix not drawn ({dark} of 7 stations)"
    # the reaction arrow: red pixels above the pivot
    tip = browser.evaluate(session, "spatialmbdViewer.screenPosition(-1, [0, 0, 0])")
    patch = img[int(tip[1]) - 80:int(tip[1]) - 5, int(tip[0]) - 8:int(tip[0]) + 9].reshape(-1, 3)
    assert ((patch[:, 0] > 150) & (patch[:, 1] < 90) & (patch[:, 2] < 90)).sum() > 30
    assert browser.errors(session) == []
    # the GPU goes away mid-session: the Canvas renderer takes over, the scene stays visible
    browser.evaluate(session, "document.getElementById('gl-canvas').getContext('webgl2')"
                              ".getExtension('WEBGL_lose_context').loseContext()")
    deadline = time.monotonic() + 5
    while browser.evaluate(session, "spatialmbdViewer.renderer()") != "canvas":
        assert time.monotonic() < deadline, "no fallback after the WebGL context was lost"
        time.sleep(0.05)
    browser.evaluate(session, "spatialmbdViewer.setTime(0.5)")
    assert "context was lost" in browser.evaluate(session, "spatialmbdViewer.fallbackReason()")
    _check_scene_shown(browser, session, "canvas", "canvas_after_context_loss")
    assert browser.errors(session) == []
    browser.close_page(session)


@pytest.mark.browser
def test_browser_canvas_fallback_without_webgl(browser, tmp_path):
    path = write_animation_html(tmp_path / "fallback.html", double_pendulum_scene())
    session = _load(browser, path, "#t=0.5", init_script=_NO_WEBGL)
    assert "WebGL 2 is not available" in browser.evaluate(session,
                                                          "spatialmbdViewer.fallbackReason()")
    assert browser.evaluate(session, "document.getElementById('gl-canvas')") is None
    _check_scene_shown(browser, session, "canvas", "canvas_fallback")
    assert browser.errors(session) == []
    browser.close_page(session)


@pytest.mark.browser
def test_browser_instancing_draw_calls_do_not_grow_with_bodies(browser, tmp_path):
    path = write_animation_html(tmp_path / "chain.html", chain_scene(20, 200))
    session = _load(browser, path, "#t=1")
    assert browser.evaluate(session, "spatialmbdViewer.renderer()") == "webgl"
    calls = browser.evaluate(session, "spatialmbdViewer.drawCalls()")
    assert browser.errors(session) == []
    browser.close_page(session)
    # 200 boxes in one instanced mesh, plus the grid (2), the ground axes (3) and the pools of
    # line-like items: a dozen calls, where one mesh per body would need 200
    assert 0 < calls <= 12, calls


# ----------------------------------------------------------------------------------------------
# triangle meshes (spatialmbd.meshes) in both renderers
# ----------------------------------------------------------------------------------------------
def _mesh_pendulum_scene():
    from test_meshes import cube_mesh
    scene = double_pendulum_scene()
    V, F = cube_mesh(1.0)
    link = {"type": "mesh", "vertices": V * [1.0, 0.08, 0.12], "faces": F}
    for body in scene["bodies"]:
        body["shapes"] = [link]
    return scene


@pytest.mark.browser
@pytest.mark.parametrize("renderer", ["webgl", "canvas"])
def test_browser_draws_meshes(browser, tmp_path, renderer):
    path = write_animation_html(tmp_path / f"mesh_{renderer}.html", _mesh_pendulum_scene())
    session = _load(browser, path, "#t=0.5",
                    init_script=_NO_WEBGL if renderer == "canvas" else None)
    _check_scene_shown(browser, session, renderer, f"mesh_{renderer}")
    assert browser.errors(session) == []
    browser.close_page(session)


def travelling_cart_scene(n_frames=101, t_end=5.0, speed=4.0):
    """A 1 m cart driving 20 m along x: it travels 20 times its own size."""
    t = np.linspace(0.0, t_end, n_frames)
    r = np.stack([speed * t, 0 * t, 0.25 + 0 * t], axis=1)
    p = np.tile([1.0, 0.0, 0.0, 0.0], (n_frames, 1))
    return {"t": t, "bodies": [{"name": "cart", "r": r, "p": p,
                                "shapes": [{"type": "box", "size": [1.0, 0.5, 0.3],
                                            "center": [0, 0, 0]}]}],
            "gravity": [0, 0, -9.81]}


@pytest.mark.browser
def test_browser_follows_a_travelling_mechanism(browser, pendulum_page, tmp_path):
    """A mechanism travelling many times its size is followed by the camera (on by default,
    the checkbox ticked): the camera looks at the cart wherever it is; #follow=0 or
    setFollow(false) frame the whole motion again. A pendulum is not followed."""
    page = write_animation_html(tmp_path / "cart.html", travelling_cart_scene(), title="cart")
    session = _load(browser, page, "#t=0")
    assert browser.evaluate(session, "spatialmbdViewer.isFollowing()") is True
    assert browser.evaluate(session, "document.getElementById('chk-follow').checked") is True
    for t in (0.0, 2.5, 5.0):
        target = browser.evaluate(session, f"spatialmbdViewer.setTime({t}), "
                                           "spatialmbdViewer.cameraTarget()")
        assert np.allclose(target, [4.0 * t, 0.0, 0.25], atol=1e-9), (t, target)
    browser.evaluate(session, "spatialmbdViewer.setFollow(false)")
    whole = browser.evaluate(session, "spatialmbdViewer.cameraTarget()")
    assert abs(whole[0] - 10.0) < 1.5                     # the middle of the whole 20 m
    session = _load(browser, page, "#follow=0")
    assert browser.evaluate(session, "spatialmbdViewer.isFollowing()") is False
    assert browser.errors(session) == []
    session = _load(browser, pendulum_page, "#t=0")
    assert browser.evaluate(session, "spatialmbdViewer.isFollowing()") is False


# ----------------------------------------------------------------------------------------------
# the camera frames the moving bodies
# ----------------------------------------------------------------------------------------------
def _with_far_dummy(scene, distance=40.0):
    """The scene with a static dummy body parked ``distance`` m away along x (a MuJoCo
    model's mocap or a helper frame) and a static base next to the pivot."""
    scene["bodies"] = scene["bodies"] + [
        {"name": "dummy", "r": [distance, 0, 0], "p": [1, 0, 0, 0],
         "shapes": [{"type": "box", "size": [0.2, 0.2, 0.2]}]},
        {"name": "base", "r": np.tile([0.0, 0.0, 0.3], (len(scene["t"]), 1)),
         "p": np.tile([1.0, 0, 0, 0], (len(scene["t"]), 1)),
         "shapes": [{"type": "box", "size": [0.4, 0.4, 0.1]}]}]
    return scene


def test_bodies_that_move_are_marked_for_the_camera():
    data = _embedded_scene(animation_html(_with_far_dummy(double_pendulum_scene())))
    assert [b["moving"] for b in data["bodies"]] == [True, True, False, False]
    still = {"t": [0.0, 1.0], "bodies": [{"r": np.tile([1.0, 2, 3], (2, 1)) + [[0, 0, 0],
                                                                             [0, 0, 1e-9]],
                                         "p": np.tile([1.0, 0, 0, 0], (2, 1))}]}
    assert _embedded_scene(animation_html(still))["bodies"][0]["moving"] is False


@pytest.mark.browser
def test_browser_camera_frames_the_moving_bodies_not_a_far_dummy(browser, tmp_path):
    """A double pendulum (2 m across) with a static dummy body 40 m away and a static base
    beside its pivot: the camera looks at the pendulum's box (with the base, which is near),
    not the dummy (whose box would put the target about 20 m along x)."""
    scene = _with_far_dummy(double_pendulum_scene())
    page = write_animation_html(tmp_path / "dummy.html", scene)
    session = _load(browser, page, "#t=0")
    assert browser.evaluate(session, "spatialmbdViewer.isFollowing()") is False
    target = np.array(browser.evaluate(session, "spatialmbdViewer.cameraTarget()"))
    # the centre of the box of the links' trajectories (with their shapes), the base and the
    # origin: within the pendulum's reach of the pivot
    links = np.concatenate([b["r"] for b in scene["bodies"][:2]])
    centre = 0.5 * (links.min(axis=0) + links.max(axis=0))
    assert np.abs(target - centre).max() < 0.35, (target, centre)
    assert browser.errors(session) == []
