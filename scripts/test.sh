#!/usr/bin/env bash
# Install spatialmbd with its test dependencies and run the whole test suite.
# Browser tests need headless Chromium: it is installed from Debian's packages when missing
# and we are root with apt-get (else those tests are skipped, unless
# SPATIALMBD_REQUIRE_BROWSER=1 makes them fail). Extra arguments go to pytest; the tests run in
# parallel, one process per core (pytest-xdist).
set -euo pipefail
cd "$(dirname "$0")/.."
python -m pip install --quiet --disable-pip-version-check -e ".[test]"
if [ -z "${SPATIALMBD_CHROMIUM:-}" ] && ! command -v chromium >/dev/null 2>&1; then
    if [ "$(id -u)" = "0" ] && command -v apt-get >/dev/null 2>&1; then
        echo "installing headless Chromium for the browser tests (apt-get)..."
        (apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq chromium >/dev/null) \
            || echo "could not install chromium: browser tests will be skipped"
    else
        echo "chromium not found: browser tests will be skipped (install it to run them)"
    fi
fi
# one worker per core (pytest-xdist); the kernels are compiled once, before the workers start
# (tests/conftest.py)
exec python -m pytest -n auto --dist worksteal "$@"
