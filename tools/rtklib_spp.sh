#!/bin/sh
# Regenerate RTKLIB's single-point solutions for the GEONET files with the
# options in tools/rtklib_spp.conf (RTKLIB rnx2rtkp, Debian package `rtklib`).
# Usage: NAVFUSE_DATA=../shared/data tools/rtklib_spp.sh [OUTDIR]
# Writes OUTDIR/0759.rtklib.pos and OUTDIR/3040.rtklib.pos (ECEF, GPST TOW).
set -eu
here=$(cd "$(dirname "$0")" && pwd)
data=${NAVFUSE_DATA:-$here/../../shared/data}
out=${1:-.}
command -v rnx2rtkp >/dev/null || { echo "rnx2rtkp not found (apt-get install rtklib)" >&2; exit 3; }
mkdir -p "$out"
for s in 0759 3040; do
    obs=$data/gnss/rinex/${s}0920.05o
    nav=$data/gnss/rinex/${s}0920.05n
    [ -f "$obs" ] && [ -f "$nav" ] || { echo "real data missing: $obs / $nav (set NAVFUSE_DATA)" >&2; exit 3; }
    rnx2rtkp -k "$here/rtklib_spp.conf" -o "$out/$s.rtklib.pos" "$obs" "$nav" 2>/dev/null
    echo "$out/$s.rtklib.pos: $(grep -vc '^%' "$out/$s.rtklib.pos") epochs"
done
