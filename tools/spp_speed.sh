#!/bin/sh
# Wall time of `navfuse spp` against RTKLIB `rnx2rtkp` single mode on the same
# GEONET file, both as processes (start-up, reading, solving, writing),
# alternating, median of N runs each (issue 14 must-show 4, GEONET part).
# Usage: NAVFUSE_DATA=../shared/data tools/spp_speed.sh [NAVFUSE_BIN] [N]
set -eu
here=$(cd "$(dirname "$0")" && pwd)
data=${NAVFUSE_DATA:-$here/../../shared/data}
bin=${1:-$here/../target/release/navfuse}
n=${2:-21}
command -v rnx2rtkp >/dev/null || { echo "rnx2rtkp not found (apt-get install rtklib)" >&2; exit 3; }
tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT
for s in 0759 3040; do
    obs=$data/gnss/rinex/${s}0920.05o; nav=$data/gnss/rinex/${s}0920.05n
    [ -f "$obs" ] || { echo "real data missing: $obs (set NAVFUSE_DATA)" >&2; exit 3; }
    : > "$tmp/a"; : > "$tmp/b"
    i=0
    while [ $i -lt "$n" ]; do
        t0=$(date +%s%N); "$bin" spp "$obs" --nav "$nav" "$tmp/n.pos" 2>/dev/null; t1=$(date +%s%N)
        rnx2rtkp -k "$here/rtklib_spp.conf" -o "$tmp/r.pos" "$obs" "$nav" 2>/dev/null; t2=$(date +%s%N)
        echo $(( (t1 - t0) / 1000 )) >> "$tmp/a"; echo $(( (t2 - t1) / 1000 )) >> "$tmp/b"
        i=$((i + 1))
    done
    a=$(sort -n "$tmp/a" | sed -n "$(( (n + 1) / 2 ))p"); b=$(sort -n "$tmp/b" | sed -n "$(( (n + 1) / 2 ))p")
    echo "$s: navfuse spp ${a} us, rnx2rtkp ${b} us (median of $n); rnx2rtkp/navfuse = $(awk "BEGIN{printf \"%.2f\", $b/$a}")"
done
