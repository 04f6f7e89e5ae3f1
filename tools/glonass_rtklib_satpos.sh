#!/bin/sh
# Regenerate crates/io/testdata/glonass_rtklib/: the GLONASS records of the
# simulated multi-GNSS hour with GLONASS (seed 1) and RTKLIB rnx2rtkp's
# GLONASS satellite positions/clocks for them (its level-4 debug trace of
# `satposs`: time of transmission GPST, satellite number 33..59 = R01..R27,
# ECEF position [m], clock [ns], ephemeris variance [m²]) at seven epochs,
# two of them next to a switch of records. Checked by
# crates/io/tests/glonass_rtklib.rs.
# Usage: tools/glonass_rtklib_satpos.sh [SIM_EXAMPLE_BIN]
set -eu
here=$(cd "$(dirname "$0")" && pwd)
simbin=${1:-$here/../target/release/examples/multi_gnss_rinex}
out=$here/../crates/io/testdata/glonass_rtklib
tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT
"$simbin" "$tmp" 1 --glonass >/dev/null
awk '/END OF HEADER/{h=0; print; next} NR==1{h=1} h{print; next} /^R/{r=4} r>0{print; r--}' "$tmp/sim.nav" > "$out/sim_glonass.nav"
: > "$out/rtklib_satpos.txt"
for m in 00:00:30 00:07:00 00:14:50 00:15:20 00:29:00 00:44:59 00:58:00; do
    rnx2rtkp -x 4 -ts 2019/01/01 $m -te 2019/01/01 $m -k "$here/rtklib_spp_multi_glo.conf" \
        -o "$tmp/tr.pos" "$tmp/sim.obs" "$tmp/sim.nav" >/dev/null 2>&1
    grep "rs=" "$tmp/tr.pos.trace" | python3 -c "
import re, sys
for l in sys.stdin:
    m = re.match(r'4 (\S+) (\S+) sat=\s*(\d+) rs=\s*(\S+)\s+(\S+)\s+(\S+) dts=\s*(\S+) var=\s*(\S+)', l)
    if m and 33 <= int(m.group(3)) <= 59:
        print(' '.join(m.groups()))
" >> "$out/rtklib_satpos.txt"
done
wc -l "$out/rtklib_satpos.txt"
