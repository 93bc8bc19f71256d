#!/usr/bin/env bash
# Installs code-server 4.100.3 (VS Code 1.100.3 in a browser) and playwright-core
# into DIR (default: $MDG_E2E_DIR, else ~/.cache/mdg/vscode-e2e), offline-safe:
# no postinstall script runs (they download binaries); their work is done here by
# hand, as docs/editors.md describes. Idempotent: a stamp holding the lockfile's
# hash skips everything when DIR is already installed from the same lockfile.
#
# Needs: node 20 with npm, a C++ toolchain, and the Debian packages libkrb5-dev
# (kerberos) and ripgrep (VS Code's search); .ci/run installs them.
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
mkdir -p "$dir"
rm -f "$stamp"
cp "$here/package.json" "$here/package-lock.json" "$dir/"
cd "$dir"
export PLAYWRIGHT_SKIP_BROWSER_DOWNLOAD=1
npm ci --ignore-scripts --no-audit --no-fund --loglevel=error

gyp="node $(npm root -g)/npm/node_modules/node-gyp/bin/node-gyp.js"
cs="$dir/node_modules/code-server"
vs="$cs/lib/vscode"

# code-server's postinstall.sh, by hand.
(cd "$vs" && npm install --omit=dev --ignore-scripts --no-audit --no-fund --loglevel=error)
for m in kerberos @vscode/spdlog native-watchdog @vscode/deviceid node-pty; do
  (cd "$vs/node_modules/$m" && $gyp rebuild --nodedir=/usr --loglevel=error >/dev/null)
done
mkdir -p "$vs/node_modules/@vscode/ripgrep/bin"
ln -sf /usr/bin/rg "$vs/node_modules/@vscode/ripgrep/bin/rg"
ln -sfn node_modules "$vs/node_modules.asar"
(cd "$vs/bin/remote-cli" && ln -sf code-linux.sh code-server)
(cd "$vs/bin/helpers" && ln -sf browser-linux.sh browser.sh)
(cd "$vs/extensions" && npm install --omit=dev --ignore-scripts --no-audit --no-fund --loglevel=error && node postinstall.mjs >/dev/null)
# argon2 is loaded even with `auth: none` (npm may have hoisted it).
argon2="$(node -p "require('path').dirname(require.resolve('argon2/package.json', {paths: ['$cs']}))")"
(cd "$argon2" && "$dir/node_modules/.bin/node-pre-gyp" rebuild --nodedir=/usr --loglevel=error >/dev/null)

echo "$want" >"$stamp"
echo "vscode-e2e: installed code-server and playwright-core in $dir in $(( $(date +%s) - t0 )) s"
