#!/bin/sh
# A platform .vsix: the extension with mdg-lsp, mdg-run, the std library and
# docs/diagnostics.md inside it, used by default (settings left empty).
#
#   sh scripts/package-platform.sh [TARGET]      # TARGET: linux-x64 (default), linux-arm64, …
#
# The binaries come from $MDG_BIN_DIR (default: ../../target/release, built first
# with `cargo build --release -p mdg-lsp -p mdg-cli --bin mdg-lsp --bin mdg-run`
# unless MDG_BIN_DIR is given). They must be built for TARGET; only the host's
# target can be built here without a cross toolchain.
set -eu
here=$(cd "$(dirname "$0")/.." && pwd)
root=$(cd "$here/../.." && pwd)
target=${1:-linux-x64}
if [ -z "${MDG_BIN_DIR:-}" ]; then
  (cd "$root" && cargo build --release -p mdg-lsp -p mdg-cli --bin mdg-lsp --bin mdg-run)
  bin_dir=${CARGO_TARGET_DIR:-$root/target}/release
else
  bin_dir=$MDG_BIN_DIR
fi
for b in mdg-lsp mdg-run; do
  [ -x "$bin_dir/$b" ] || { echo "package-platform: $bin_dir/$b is missing" >&2; exit 1; }
done
version=$(node -p "require('$here/package.json').version")
out=${MDG_VSIX_OUT:-$here/mdg-$target-$version.vsix}
cleanup() { rm -rf "$here/bin" "$here/std" "$here/docs"; }
trap cleanup EXIT
cleanup
mkdir -p "$here/bin" "$here/docs"
cp "$bin_dir/mdg-lsp" "$bin_dir/mdg-run" "$here/bin/"
cp -R "$root/std" "$here/std"
cp "$root/docs/diagnostics.md" "$here/docs/"
(cd "$here" && npx vsce package --allow-missing-repository --no-dependencies --target "$target" -o "$out")
echo "package-platform: $out"
