#!/usr/bin/env bash
# Installs code-server 4.100.3 (VS Code 1.100.3 in a browser) and playwright-core
# into DIR (default: $MDG_E2E_DIR, else ~/.cache/mdg/vscode-e2e), offline-safe:
# no postinstall script runs (they download binaries); their work is done here by
# hand, as docs/editors.md describes. Idempotent: a stamp holding the lockfile's
# hash skips everything when DIR is already installed from the same lockfile.
#
# Needs: node 20 with npm and its headers (Debian's or NodeSource's node under /usr,
# or the PyPI wheel .ci/run installs when the system's node is older), a C++
# toolchain, and the Debian packages libkrb5-dev (kerberos) and ripgrep (VS Code's
# search); .ci/run installs them. The native modules are compiled from source (their
# prebuilt binaries are downloads from outside the package registries), with every
# core (`-j max`).
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
dir="${1:-${MDG_E2E_DIR:-$HOME/.cache/mdg/vscode-e2e}}"
stamp="$dir/.installed"
want="$(sha256sum "$here/package-lock.json" | cut -d' ' -f1)"
if [ -f "$stamp" ] && [ "$(cat "$stamp")" = "$want" ]; then
  echo "vscode-e2e: already installed in $dir"
  exit 0
fi
t0=$(date +%s)
t_lap=$t0
lap() { local now; now=$(date +%s); echo "vscode-e2e: $1: $((now - t_lap)) s"; t_lap=$now; }
mkdir -p "$dir"
rm -f "$stamp"
cp "$here/package.json" "$here/package-lock.json" "$dir/"
cd "$dir"
export PLAYWRIGHT_SKIP_BROWSER_DOWNLOAD=1
npm ci --ignore-scripts --no-audit --no-fund --loglevel=error
lap "npm ci (code-server, playwright-core)"

gyp="node $(npm root -g)/npm/node_modules/node-gyp/bin/node-gyp.js"
# The headers of the node that runs code-server: its prefix's include/node (node-gyp
# would otherwise download them).
nodedir="$(node -p 'require("path").resolve(process.execPath, "..", "..")')"
if [ ! -f "$nodedir/include/node/common.gypi" ]; then
  echo "vscode-e2e: no Node.js headers at $nodedir/include/node (install the node package's headers, e.g. Debian's libnode-dev)" >&2
  exit 1
fi
cs="$dir/node_modules/code-server"
vs="$cs/lib/vscode"

# code-server's postinstall.sh, by hand.
(cd "$vs" && npm install --omit=dev --ignore-scripts --no-audit --no-fund --loglevel=error)
lap "npm install (VS Code's modules)"
for m in kerberos @vscode/spdlog native-watchdog @vscode/deviceid node-pty; do
  (cd "$vs/node_modules/$m" && $gyp rebuild --nodedir="$nodedir" -j max --loglevel=error >/dev/null)
  lap "node-gyp rebuild $m"
done
mkdir -p "$vs/node_modules/@vscode/ripgrep/bin"
ln -sf /usr/bin/rg "$vs/node_modules/@vscode/ripgrep/bin/rg"
ln -sfn node_modules "$vs/node_modules.asar"
(cd "$vs/bin/remote-cli" && ln -sf code-linux.sh code-server)
(cd "$vs/bin/helpers" && ln -sf browser-linux.sh browser.sh)
(cd "$vs/extensions" && npm install --omit=dev --ignore-scripts --no-audit --no-fund --loglevel=error && node postinstall.mjs >/dev/null)
lap "npm install (VS Code's extensions)"
# argon2 is loaded even with `auth: none` (npm may have hoisted it).
argon2="$(node -p "require('path').dirname(require.resolve('argon2/package.json', {paths: ['$cs']}))")"
(cd "$argon2" && "$dir/node_modules/.bin/node-pre-gyp" rebuild --nodedir="$nodedir" --loglevel=error >/dev/null)
lap "node-pre-gyp rebuild argon2"

echo "$want" >"$stamp"
echo "vscode-e2e: installed code-server and playwright-core in $dir in $(( $(date +%s) - t0 )) s"
