#!/bin/sh
# Wall time of `navfuse spp` against RTKLIB `rnx2rtkp` single mode on the same
# files, both as processes (start-up, reading, solving, writing),
# alternating in one run, median of N runs each (issue 14 must-show 4):
#  - the GEONET hours 0759 and 3040 (GPS, RINEX 2, tools/rtklib_spp.conf);
#  - the simulated 1 h, 1 Hz GPS + Galileo + BeiDou rover log (RINEX 3.04,
#    written by `cargo run --release -p navfuse-sim --example multi_gnss_rinex`,
#    tools/rtklib_spp_multi.conf with navsys GPS+GAL+BDS), with an
#    epoch-by-epoch comparison of the two solutions and of both against the
#    simulator's truth;
#  - the same hour with the simulated GLONASS constellation added
#    (`multi_gnss_rinex OUT 1 --glonass`, tools/rtklib_spp_multi_glo.conf,
#    navsys GPS+GLO+GAL+BDS), compared the same way.
# Usage: NAVFUSE_DATA=../shared/data tools/spp_speed.sh [NAVFUSE_BIN] [N] [SIM_EXAMPLE_BIN]
set -eu
here=$(cd "$(dirname "$0")" && pwd)
data=${NAVFUSE_DATA:-$here/../../shared/data}
bin=${1:-$here/../target/release/navfuse}
n=${2:-21}
simbin=${3:-$here/../target/release/examples/multi_gnss_rinex}
command -v rnx2rtkp >/dev/null || { echo "rnx2rtkp not found (apt-get install rtklib)" >&2; exit 3; }
tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT
# time_pair LABEL OBS NAV CONF
time_pair() {
    : > "$tmp/a"; : > "$tmp/b"
    i=0
    while [ $i -lt "$n" ]; do
        t0=$(date +%s%N); "$bin" spp "$2" --nav "$3" "$tmp/n.pos" >/dev/null 2>&1; t1=$(date +%s%N)
        rnx2rtkp -k "$4" -o "$tmp/r.pos" "$2" "$3" >/dev/null 2>&1; t2=$(date +%s%N)
        echo $(( (t1 - t0) / 1000 )) >> "$tmp/a"; echo $(( (t2 - t1) / 1000 )) >> "$tmp/b"
        i=$((i + 1))
    done
    a=$(sort -n "$tmp/a" | sed -n "$(( (n + 1) / 2 ))p"); b=$(sort -n "$tmp/b" | sed -n "$(( (n + 1) / 2 ))p")
    echo "$1: navfuse spp ${a} us, rnx2rtkp ${b} us (median of $n); rnx2rtkp/navfuse = $(awk "BEGIN{printf \"%.2f\", $b/$a}")"
}
for s in 0759 3040; do
    obs=$data/gnss/rinex/${s}0920.05o; nav=$data/gnss/rinex/${s}0920.05n
    [ -f "$obs" ] || { echo "real data missing: $obs (set NAVFUSE_DATA)" >&2; exit 3; }
    time_pair "$s" "$obs" "$nav" "$here/rtklib_spp.conf"
done
[ -x "$simbin" ] || { echo "$simbin missing: cargo build --release -p navfuse-sim --example multi_gnss_rinex" >&2; exit 3; }
"$simbin" "$tmp/sim"
time_pair "sim 1 h G+E+C" "$tmp/sim/sim.obs" "$tmp/sim/sim.nav" "$here/rtklib_spp_multi.conf"
python3 "$here/spp_multi_compare.py" "$tmp/n.pos" "$tmp/r.pos" "$tmp/sim/truth.csv"
# Which systems rnx2rtkp used: its residual status file lists every satellite
# of each solution.
{ cat "$here/rtklib_spp_multi.conf"; echo "out-outstat        =residual"; } > "$tmp/stat.conf"
rnx2rtkp -k "$tmp/stat.conf" -o "$tmp/rs.pos" "$tmp/sim/sim.obs" "$tmp/sim/sim.nav" >/dev/null 2>&1
awk -F, '/^\$SAT/{n[substr($4,1,1)]++; if (!($3 in e)) {e[$3]=1; ne++}}
    END{printf "rnx2rtkp satellites used per epoch: G %.2f, E %.2f, C %.2f (%d epochs)\n", n["G"]/ne, n["E"]/ne, n["C"]/ne, ne}' "$tmp/rs.pos.stat"
"$simbin" "$tmp/simr" 1 --glonass
time_pair "sim 1 h G+E+C+R" "$tmp/simr/sim.obs" "$tmp/simr/sim.nav" "$here/rtklib_spp_multi_glo.conf"
python3 "$here/spp_multi_compare.py" "$tmp/n.pos" "$tmp/r.pos" "$tmp/simr/truth.csv"
{ cat "$here/rtklib_spp_multi_glo.conf"; echo "out-outstat        =residual"; } > "$tmp/statr.conf"
rnx2rtkp -k "$tmp/statr.conf" -o "$tmp/rsr.pos" "$tmp/simr/sim.obs" "$tmp/simr/sim.nav" >/dev/null 2>&1
awk -F, '/^\$SAT/{n[substr($4,1,1)]++; if (!($3 in e)) {e[$3]=1; ne++}}
    END{printf "rnx2rtkp satellites used per epoch: G %.2f, R %.2f, E %.2f, C %.2f (%d epochs)\n", n["G"]/ne, n["R"]/ne, n["E"]/ne, n["C"]/ne, ne}' "$tmp/rsr.pos.stat"
