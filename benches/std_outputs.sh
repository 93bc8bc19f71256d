#!/usr/bin/env bash
# Writes the default `.glb` and the `.json` of every std example into DIR (and the
# `.glb` with sites, `--sites`, as `.sites.glb`: the evaluator's recording loop; and
# the instanced `.glb`, `--instances`, as `.instances.glb`: the instance records), so
# that two builds of the evaluator can be compared byte for byte:
#
#   benches/std_outputs.sh /tmp/before            # with the old build
#   benches/std_outputs.sh /tmp/after             # with the new one
#   diff -r /tmp/before /tmp/after && echo identical
#
# MDG_RUN names the `mdg-run` binary (default target/debug/mdg-run, built first).
# `monsters` writes a folder: it is written as DIR/monsters/.
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:?usage: benches/std_outputs.sh DIR}
if [ -z "${MDG_RUN:-}" ]; then
  cargo build -q -p mdg-cli --bin mdg-run
  MDG_RUN=target/debug/mdg-run
fi
mkdir -p "$out"
for f in std/examples/*.mdg; do
  name=$(basename "$f" .mdg)
  if [ "$name" = monsters ]; then
    "$MDG_RUN" "$f" -o "$out/monsters/" > /dev/null 2> "$out/$name.log" || echo "exit $?" >> "$out/$name.log"
    continue
  fi
  for ext in glb json; do
    "$MDG_RUN" "$f" -o "$out/$name.$ext" > /dev/null 2> "$out/$name.$ext.log" || echo "exit $?" >> "$out/$name.$ext.log"
  done
  "$MDG_RUN" "$f" --sites -o "$out/$name.sites.glb" > /dev/null 2> "$out/$name.sites.log" \
    || echo "exit $?" >> "$out/$name.sites.log"
  "$MDG_RUN" "$f" --instances -o "$out/$name.instances.glb" > /dev/null 2> "$out/$name.instances.log" \
    || echo "exit $?" >> "$out/$name.instances.log"
done
# (Elapsed times in the logs differ from run to run, and the output folder's name.)
sed -i -E 's/[0-9]+(\.[0-9]+)? ?(ms|s)\b/TIME/g' "$out"/*.log
sed -i "s|$out|DIR|g" "$out"/*.log "$out"/monsters/index.html
