#!/usr/bin/env bash
# Assembles Lumen's Unity package (UPM) for Linux x86_64: package.json, Runtime/ (Lumen.cs from
# client/csharp, its assembly definition, Plugins/x86_64/liblumen_c.so stripped, with its import
# settings), Samples~/ and the README; then checks the layout. In Unity: Window > Package
# Manager > + > Add package from disk..., and pick OUT/package.json.
#
#   bash client/unity/build.sh [--out DIR] [--lib liblumen_c.so]
#
# Default: builds the library (cargo build --release -p lumen-c) and writes
# target/unity/org.lumen.client. --lib takes an already built library instead (the tests use
# the debug one).
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/../.." && pwd)
out="$root/target/unity/org.lumen.client"
lib=""
while [ $# -gt 0 ]; do
  case "$1" in
    --out) out=$2; shift 2 ;;
    --lib) lib=$2; shift 2 ;;
    *) echo "build.sh: unknown argument $1 (--out DIR, --lib FILE)" >&2; exit 2 ;;
  esac
done
if [ -z "$lib" ]; then
  (cd "$root" && cargo build --release -p lumen-c)
  lib="$root/target/release/liblumen_c.so"
fi
[ -f "$lib" ] || { echo "build.sh: no library at $lib" >&2; exit 1; }

rm -rf "$out"
mkdir -p "$out/Runtime/Plugins/x86_64"
cp "$here/package.json" "$here/README.md" "$out/"
cp "$here/Runtime/Lumen.Runtime.asmdef" "$root/client/csharp/Lumen.cs" "$out/Runtime/"
cp -r "$here/Samples~" "$out/"
# Debug information and the symbol table out: about 15 MB instead of about 100 (release).
strip --strip-unneeded -o "$out/Runtime/Plugins/x86_64/liblumen_c.so" "$lib"
cp "$here/Plugins/liblumen_c.so.meta" "$out/Runtime/Plugins/x86_64/"

# The layout Unity expects, and a library that has lumen.h's functions.
for f in package.json README.md Runtime/Lumen.cs Runtime/Lumen.Runtime.asmdef \
         Runtime/Plugins/x86_64/liblumen_c.so Runtime/Plugins/x86_64/liblumen_c.so.meta \
         Samples~/ScopeContacts/ScopeContacts.cs Samples~/ScopeContacts/Lumen.Samples.asmdef; do
  [ -f "$out/$f" ] || { echo "build.sh: $f missing from the package" >&2; exit 1; }
done
for fn in lumen_client_local lumen_client_zenoh lumen_session_open lumen_session_close lumen_last_error; do
  nm -D --defined-only "$out/Runtime/Plugins/x86_64/liblumen_c.so" | grep -q " $fn\$" || { echo "build.sh: the library lacks $fn" >&2; exit 1; }
done
echo "package: $out ($(du -k "$out/Runtime/Plugins/x86_64/liblumen_c.so" | cut -f1) KiB library)"
