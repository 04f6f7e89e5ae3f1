#!/bin/sh
# Wall time of navfuse's RTK paths against RTKLIB `rnx2rtkp` kinematic on the
# same files, both as processes (start-up, reading, solving, writing),
# alternating in one run, median of N runs each (issue 15 must-show 4):
#  - the GEONET hour (rover 3040, base 0759, 30 s, GPS L1+L2):
#    `navfuse baseline --kinematic --l2 --via-rtk` (the RTK/INS core with the
#    INS off) against `rnx2rtkp` with tools/rtklib_rtk_gps.conf;
#  - a simulated 1 h, 1 Hz car with a consumer IMU (100 Hz) and a
#    dual-frequency GPS + Galileo + BeiDou rover + base pair (RINEX 3.04,
#    written by `cargo run --release -p navfuse-sim --example rtk_car_rinex
#    OUT 1 3600`):
#      * the same GNSS-only path (GPS L1+L2 only: `baseline` reads GPS)
#        against `rnx2rtkp` GPS L1+L2 (tools/rtklib_rtk_gps.conf);
#      * `navfuse run` with `coupling = "rtk"` (the RTK/INS filter: 360 000
#        IMU samples, G+E+C, writes .nav/.pos/.std/journal at 100 Hz) against
#        `rnx2rtkp` G+E+C L1+L2 (tools/rtklib_rtk_multi.conf).
#    The fixed share of each output is printed beside its time.
# A ratio rnx2rtkp/navfuse ≥ 1 means navfuse is at least as fast.
# Measured 2026-11-27 (N = 5, shared 2-core machine at load ≈ 7): GEONET 1.38,
# sim GNSS-only 1.05, sim RTK/INS run 1.09 (0.77 / 0.77 on the simulated hour
# before the speed commits of that day; outputs byte-identical across them).
# Then, with the per-satellite ionosphere states (RTK block 51 → 75) and
# Galileo/BeiDou second frequencies in `run` (N = 3): 0.98 / 0.77 / 0.58.
# Then sparse DD products and the block-wise joint update: 1.61 / 1.09 / 0.73;
# then the tiled cross-covariance propagation, the column-wise rank-1
# downdate, one LAMBDA decorrelation per attempt and the fast fixed-point
# writers (2026-11-27, N = 3): 3.52 / 2.08 / 1.18; N = 5, machine otherwise
# idle: 3.22 / 1.95 / 1.16.
# Usage: NAVFUSE_DATA=../shared/data tools/rtk_speed.sh [NAVFUSE_BIN] [N] [SIM_EXAMPLE_BIN]
set -eu
here=$(cd "$(dirname "$0")" && pwd)
data=${NAVFUSE_DATA:-$here/../../shared/data}
bin=${1:-$here/../target/release/navfuse}
n=${2:-5}
simbin=${3:-$here/../target/release/examples/rtk_car_rinex}
command -v rnx2rtkp >/dev/null || { echo "rnx2rtkp not found (apt-get install rtklib)" >&2; exit 3; }
tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT
med() { sort -n "$1" | sed -n "$(( (n + 1) / 2 ))p"; }
# time_pair LABEL CONF ROVER BASE NAV -- NAVFUSE ARGS...
time_pair() {
    label=$1; conf=$2; rov=$3; bas=$4; nav=$5; shift 6
    : > "$tmp/a"; : > "$tmp/b"
    i=0
    while [ $i -lt "$n" ]; do
        t0=$(date +%s%N); "$bin" "$@" >"$tmp/n.out" 2>&1; t1=$(date +%s%N)
        rnx2rtkp -k "$conf" -o "$tmp/r.pos" "$rov" "$bas" "$nav" >/dev/null 2>&1; t2=$(date +%s%N)
        echo $(( (t1 - t0) / 1000 )) >> "$tmp/a"; echo $(( (t2 - t1) / 1000 )) >> "$tmp/b"
        i=$((i + 1))
    done
    a=$(med "$tmp/a"); b=$(med "$tmp/b")
    rq=$(awk '!/^%/{n++; if ($6 == 1) f++} END{printf "%.1f %% of %d epochs fixed", 100 * f / (n ? n : 1), n}' "$tmp/r.pos")
    echo "$label: navfuse ${a} us, rnx2rtkp ${b} us (median of $n); rnx2rtkp/navfuse = $(awk "BEGIN{printf \"%.2f\", $b/$a}")"
    echo "    rnx2rtkp: $rq"
}
obs_r=$data/gnss/rinex/30400920.05o; obs_b=$data/gnss/rinex/07590920.05o; nav=$data/gnss/rinex/07590920.05n
[ -f "$obs_r" ] || { echo "real data missing: $obs_r (set NAVFUSE_DATA)" >&2; exit 3; }
time_pair "GEONET 3040 vs 0759, 1 h, GPS L1+L2" "$here/rtklib_rtk_gps.conf" "$obs_r" "$obs_b" "$nav" -- \
    baseline --rover "$obs_r" --base "$obs_b" --nav "$nav" --kinematic --l2 --via-rtk
echo "    navfuse: $(head -1 "$tmp/n.out")"
[ -x "$simbin" ] || { echo "$simbin missing: cargo build --release -p navfuse-sim --example rtk_car_rinex" >&2; exit 3; }
"$simbin" "$tmp/sim" 1 3600
s=$tmp/sim
time_pair "sim car 1 h, GNSS only, GPS L1+L2" "$here/rtklib_rtk_gps.conf" "$s/rover.obs" "$s/base.obs" "$s/nav.rnx" -- \
    baseline --rover "$s/rover.obs" --base "$s/base.obs" --nav "$s/nav.rnx" --kinematic --l2 --via-rtk
echo "    navfuse: $(head -1 "$tmp/n.out")"
time_pair "sim car 1 h, RTK/INS run (G+E+C) vs rnx2rtkp G+E+C L1+L2" "$here/rtklib_rtk_multi.conf" "$s/rover.obs" "$s/base.obs" "$s/nav.rnx" -- \
    run "$s/rtk.toml" --output "$tmp/run"
python3 - "$tmp/run/summary.json" <<'EOF'
import json, sys
r = json.load(open(sys.argv[1]))["rtk"]
print("    navfuse run: %d RTK epochs applied, %.1f %% fixed (%d partial), first fix after %s s"
      % (r["rover_epochs_applied"], 100 * r["fix_rate"], r["fixed_partial"], r["first_fix_after_s"]))
EOF
