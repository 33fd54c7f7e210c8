#!/usr/bin/env bash
# Round-trip latency of the clients on one daemon, one scene (the straight tube of
# client/c/examples/straight_tube_scene.h, 25 contacts a frame), each transport: the Rust client
# (client/c/examples/latency.rs), the C client (latency.c, over liblumen_c.a), the C# wrapper
# (client/csharp/examples/Latency.cs under Mono, over liblumen_c.so) and the Python package
# (client/python/examples/latency.py), alternated round by round in one run. Prints
# each round, then per client the median over rounds of its p50 and p99, and the difference to
# Rust. Release builds throughout.
#
#   bash client/latency.sh [ROUNDS] [FRAMES]        (default 7 rounds of 2000 frames)
set -euo pipefail
cd "$(dirname "$0")/.."
rounds=${1:-7}
frames=${2:-2000}
work=$(mktemp -d)
prefix="latency$$_"
port=$((20000 + $$ % 20000))
cargo build --release -q -p lumen-cli --bin lumen -p lumen-c --example latency --lib
cc -std=c11 -O2 -Iclient/c/include client/c/examples/latency.c target/release/deps/liblumen_c.a \
    -lgcc_s -lutil -lrt -lpthread -lm -ldl -lc -o "$work/latency_c"
python=${PYTHON:-python3}
clients=(rust c)
if command -v mcs >/dev/null && command -v mono >/dev/null; then
    mcs -out:"$work/Latency.exe" client/csharp/Lumen.cs client/csharp/examples/Latency.cs
    clients+=(csharp)
else
    echo "csharp: Mono's mcs and mono are not installed (apt-get install mono-mcs mono-runtime); skipped" >&2
fi
if "$python" -c "import lumen" 2>/dev/null; then
    clients+=(python)
else
    echo "python: the lumen package is not installed for $python (pip install ./client/python); skipped" >&2
fi
target/release/lumen serve --prefix "$prefix" --log warn --zenoh-listen "tcp/127.0.0.1:$port" >"$work/serve.log" 2>&1 &
daemon=$!
trap 'kill $daemon 2>/dev/null; wait $daemon 2>/dev/null; rm -rf "$work"' EXIT
for _ in $(seq 100); do grep -q "ready" "$work/serve.log" && break; sleep 0.1; done
run() { # client transport target
    case $1 in
        rust) target/release/examples/latency "$2" "$3" "$frames" ;;
        c) "$work/latency_c" "$2" "$3" "$frames" ;;
        csharp) LD_LIBRARY_PATH=target/release mono "$work/Latency.exe" "$2" "$3" "$frames" ;;
        python) "$python" client/python/examples/latency.py "$2" "$3" "$frames" ;;
    esac
}
for transport in local zenoh; do
    target=$([ $transport = local ] && echo "$prefix" || echo "tcp/127.0.0.1:$port")
    for r in $(seq "$rounds"); do
        for client in "${clients[@]}"; do
            echo "$transport $r $(run "$client" $transport "$target")" | tee -a "$work/rounds"
        done
    done
done
"$python" - "$work/rounds" <<'PY'
import statistics, sys
rows = {}
for line in open(sys.argv[1]):
    transport, _, client, _, p50, _, _, p99, *_ = line.split()
    rows.setdefault((transport, client.rstrip(":")), []).append((float(p50), float(p99)))
print(f"\n| transport | client | p50 us (median of rounds) | p99 us | p50 - rust's |")
print("|---|---|---|---|---|")
for (transport, client), v in rows.items():
    p50, p99 = statistics.median(x for x, _ in v), statistics.median(y for _, y in v)
    rust = statistics.median(x for x, _ in rows[(transport, "rust")])
    print(f"| {'iceoryx2' if transport == 'local' else 'zenoh'} | {client} | {p50:.1f} | {p99:.1f} | {p50 - rust:+.1f} |")
PY
