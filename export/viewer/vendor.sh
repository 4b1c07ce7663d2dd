#!/bin/sh
# Rebuild three-bundle.js and LICENSE-three.txt from three.js's npm release (make vendor-three).
# Pinned versions: the bundle in the repository was built by exactly this.
set -eu
THREE=0.187.0
ESBUILD=0.28.2
here=$(cd "$(dirname "$0")" && pwd)
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT INT TERM
cd "$work"
npm init -y >/dev/null
npm install --silent --no-audit --no-fund "three@$THREE" "esbuild@$ESBUILD"
cp "$here/three-entry.mjs" entry.mjs
./node_modules/.bin/esbuild entry.mjs --bundle --minify --format=iife \
    --global-name=PLANTLOD_THREE --legal-comments=none --target=es2020 \
    --banner:js="/* three.js ${THREE} (MIT, see LICENSE-three.txt), bundled by plantlod's export/viewer/vendor.sh */" \
    --outfile="$here/three-bundle.js"
cp node_modules/three/LICENSE "$here/LICENSE-three.txt"
