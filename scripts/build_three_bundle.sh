#!/usr/bin/env bash
# Development only: rebuild the vendored three.js bundle of the WebGL viewer.
#
#   bash scripts/build_three_bundle.sh
#
# Installs the pinned npm packages `three` and `esbuild` (scripts/three_bundle/package.json) in a
# temporary directory, bundles scripts/three_bundle/entry.js (only the classes the viewer uses)
# into one minified IIFE that defines the global `THREE`, and writes
#   src/spatialmbd/viewer/three.min.js   (package data, embedded inline in every HTML page)
#   src/spatialmbd/viewer/THREE_LICENSE  (three.js's MIT notice, shipped next to it)
# Users never run this: they install spatialmbd with pip and get the bundle as package data.
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
src="$root/scripts/three_bundle"
out="$root/src/spatialmbd/viewer"
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
cp "$src/package.json" "$src/entry.js" "$work/"
(cd "$work" && npm install --no-audit --no-fund --silent)
version="$(node -p "require('$work/node_modules/three/package.json').version")"
cp "$work/node_modules/three/LICENSE" "$out/THREE_LICENSE"
# the MIT notice travels inside the bundle too, since the HTML pages embed it
banner="/*! three.js $version (threejs.org), bundled for spatialmbd. $(tr '\n' ' ' < "$out/THREE_LICENSE" | sed 's/  */ /g; s/\*\//* \//g') */"
(cd "$work" && ./node_modules/.bin/esbuild entry.js --bundle --minify --format=iife \
   --global-name=THREE --target=es2018 --legal-comments=none --banner:js="$banner" \
   --outfile="$out/three.min.js")
if grep -qi '</script' "$out/three.min.js"; then
  echo "three.min.js contains '</script'; it cannot be embedded inline" >&2
  exit 1
fi
echo "wrote $out/three.min.js ($(wc -c < "$out/three.min.js") bytes, three $version)"
