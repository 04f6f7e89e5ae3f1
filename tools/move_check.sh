#!/usr/bin/env bash
# Output-neutrality check for refactors (e.g. the move of the run pipeline
# into navfuse-pipeline): every output file and message must stay identical.
# Usage: tools/move_check.sh NAVFUSE_BIN OUT_DIR [REF_DIR]
#   1. with the old binary:  tools/move_check.sh old/navfuse /tmp/ref
#   2. with the new binary:  tools/move_check.sh target/release/navfuse /tmp/new /tmp/ref
# Runs kf-gins (full; outage --enhanced --smooth), run (ESKF with smoothing and
# extra formats; pf-lc), demo, the seed experiments, attitude, baseline,
# smooth-gps, allan, eval, report, every --help and a set of bad configs/options with
# NAVFUSE_BIN into OUT_DIR; with REF_DIR, compares every file (and each
# command's stderr) against REF_DIR byte for byte. Data: $NAVFUSE_DATA
# (default ../shared/data relative to the repo).
# Give OUT_DIR and REF_DIR paths of the same length (/tmp/ref, /tmp/new): a
# report shortens long values, so the cut falls elsewhere otherwise.
# summary.json: timing fields seconds_read/seconds_filter removed and the
# output folder replaced by a placeholder before comparing.
set -u
BIN=$(readlink -f "$1"); OUT=$(readlink -m "$2"); REF=${3:+$(readlink -f "$3")}
REPO=$(dirname "$(dirname "$(readlink -f "$0")")")
DATA=$(readlink -f "${NAVFUSE_DATA:-$REPO/../shared/data}")
D=$DATA/drive_0708/kfgins
[ -f "$D/imu.txt" ] || { echo "real data missing: $D (set NAVFUSE_DATA)" >&2; exit 2; }
mkdir -p "$OUT"
HERE=$OUT
cat > "$OUT/run.toml" <<TOML
formats = ["csv", "geojson"]

[input]
imu = "$D/imu.txt"
gnss = "$D/gnss_outage.txt"

[filter]
noise_yaml = "$D/kf-gins_outage.yaml"
lever_arm = [0.0, -0.05, 0.0]
smooth = true
TOML
run() { # name, command...
  local name=$1; shift
  "$@" > /dev/null 2> "$OUT/$name.stderr"; echo "exit $?" >> "$OUT/$name.stderr"
}
run kf_full        "$BIN" kf-gins "$D/kf-gins_full.yaml" --output "$OUT/kf_full"
run kf_outage_es   "$BIN" kf-gins "$D/kf-gins_outage.yaml" --enhanced --smooth --output "$OUT/kf_outage_es"
run run_out        "$BIN" run "$HERE/run.toml" --output "$OUT/run_out"
run run_pf         "$BIN" run "$HERE/run.toml" --estimator pf-lc --output "$OUT/run_pf"
run demo           "$BIN" demo --out "$OUT/demo" --report
# Error messages must not change either: bad configs and options.
E="$OUT/errors"; mkdir -p "$E"
base="[input]\nimu = \"$D/imu.txt\"\ngnss = \"$D/gnss_outage.txt\"\n"
printf "${base}bogus = 1\n" > "$E/unknown_key.toml"
printf "${base}[init]\nheading = \"north\"\n" > "$E/heading.toml"
printf "${base}[outage]\nstart = 1.0\nlength = 0.0\nperiod = 5.0\n" > "$E/outage.toml"
printf "formats = [\"shp\"]\n${base}" > "$E/formats.toml"
printf "${base}[filter]\npreset = \"fast\"\n" > "$E/preset.toml"
printf "${base}[input.csv]\npreset = \"x\"\n" | sed "s#kfgins/imu.txt#imu_1934_gpst.csv#" > "$E/csv_preset.toml"
printf "[input]\nimu = \"$E/none.txt\"\ngnss = \"$D/gnss_outage.txt\"\n" > "$E/missing_imu.toml"
printf "${base}imu_time_offset = \"soon\"\n" > "$E/offset.toml"
for c in unknown_key heading outage formats preset csv_preset missing_imu offset; do
  run "errors/run_$c" "$BIN" run "$E/$c.toml" --output "$E/out_$c"
done
run errors/run_no_config "$BIN" run "$E/nothing.toml"
run errors/run_estimator "$BIN" run "$HERE/run.toml" --estimator magic --output "$E/out_est"
run errors/kf_gate "$BIN" kf-gins "$D/kf-gins_full.yaml" --gate 0.5 --output "$E/out_kf"
run errors/kf_offset "$BIN" kf-gins "$D/kf-gins_full.yaml" --time-offset soon --output "$E/out_kf"
run errors/kf_until "$BIN" kf-gins "$D/kf-gins_full.yaml" --position-until 30 --output "$E/out_kf"
# Experiments and tools moved into the libraries (issue 16): their files,
# stdout and stderr; every subcommand's --help (clap attributes moved too).
runo() { # name, command... ; stdout kept
  local name=$1; shift
  "$@" > "$OUT/$name.stdout" 2> "$OUT/$name.stderr"; echo "exit $?" >> "$OUT/$name.stderr"
}
X="$OUT/x"; mkdir -p "$X"
RX=$DATA/gnss/rinex
export NAVFUSE_DATA=$DATA
runo x/seed002 "$BIN" experiment seed002 --seeds 2 --real-seeds 1 --json "$X/seed002.json" --report "$X/seed002_report"
runo x/seed002_sim "$BIN" experiment seed002 --seeds 1 --no-real --sim builtin --gm-fraction 0.5 --span 8
runo x/seed003 "$BIN" experiment seed003 --seeds 2 --epochs 300 --lambda-runs 4 --json "$X/seed003.json" --plots "$X/seed003_plots"
runo x/seed004 "$BIN" experiment seed004 --seeds 3 --json "$X/seed004.json" --report "$X/seed004_report"
runo x/seed004_sim "$BIN" experiment seed004 --seeds 2 --no-real --chord literal --kf-q 1e-6 --report "$X/seed004_sim_report"
runo x/attitude "$BIN" attitude --out "$X/attitude.csv"
runo x/attitude_car "$BIN" attitude --motion car --epochs 200 --seed 3
bl=(--rover "$RX/30400920.05o" --base "$RX/07590920.05o" --nav "$RX/07590920.05n" --nav "$RX/30400920.05n")
runo x/baseline "$BIN" baseline "${bl[@]}" --reference=-2022.7699,468.6277,-2610.2896 --out "$X/baseline.csv"
runo x/baseline_kin "$BIN" baseline "${bl[@]}" --kinematic --l2 --out "$X/baseline_kin.csv"
runo x/smooth_paper "$BIN" smooth-gps "$D/gnss_outage.txt" "$X/smooth_paper.csv" --from kfgins-gnss --gps-week 2374
runo x/smooth_sir "$BIN" smooth-gps "$D/gnss_outage.txt" "$X/smooth_sir.nav" --from kfgins-gnss --gps-week 2374 --method sir
runo x/allan "$BIN" allan "$D/imu.txt" --out "$X/allan" --toml "$X/allan_noise.toml"
runo x/eval "$BIN" eval "$OUT/kf_full/KF_GINS_Navresult.nav" --truth "$D/truth.nav" --lever-arm 0,-0.05,0 --json "$X/eval.json" --csv "$X/eval.csv" --report "$X/eval_report"
runo x/eval_outage "$BIN" eval "$OUT/kf_outage_es/KF_GINS_Navresult.nav" --truth "$D/truth.nav" --lever-arm 0,-0.05,0 --outages 120,90,30,243262 --fixes "$D/gnss_outage.txt" --at reference --json "$X/eval_outage.json" --json-errors
runo x/report "$BIN" report "$OUT/run_out" --truth "$D/truth.nav" --lever-arm 0,-0.05,0 --out "$X/report_run"
# Their errors.
runo x/err_seed002 "$BIN" experiment seed002 --seeds 0
runo x/err_seed002_gm "$BIN" experiment seed002 --gm-fraction 2 --no-real
runo x/err_seed004 "$BIN" experiment seed004 --chord sideways --no-real
runo x/err_seed004_mount "$BIN" experiment seed004 --mount-rpy-deg 1,2
runo x/err_baseline "$BIN" baseline "${bl[@]}" --max-gdop 0
runo x/err_baseline_ref "$BIN" baseline "${bl[@]}" --reference 1,2
runo x/err_baseline_file "$BIN" baseline --rover "$X/none.05o" --base "$RX/07590920.05o" --nav "$RX/07590920.05n"
runo x/err_smooth "$BIN" smooth-gps "$D/gnss_outage.txt" "$X/bad.csv" --from kfgins-gnss --sigma-m 0
runo x/err_smooth_w "$BIN" smooth-gps "$D/gnss_outage.txt" "$X/bad.csv" --from kfgins-gnss --w-min 2
runo x/err_allan "$BIN" allan "$X/none.txt" --out "$X/allan_none"
runo x/err_eval "$BIN" eval "$X/none.xyz" --truth "$D/truth.nav"
runo x/err_eval_outages "$BIN" eval "$OUT/kf_full/KF_GINS_Navresult.nav" --truth "$D/truth.nav" --outages 1,2
runo x/err_demo "$BIN" demo --scenario "$X/none.toml" --out "$X/demo_none"
for c in convert run init kf-gins eval bench sim allan demo attitude baseline experiment smooth-gps report live; do
  runo "x/help_$c" "$BIN" "$c" --help
done
for c in seed002 seed003 seed004 generalise align; do
  runo "x/help_experiment_$c" "$BIN" experiment "$c" --help
done
[ -z "$REF" ] && exit 0
norm() { # file, its root dir -> normalised text on stdout
  case "$1" in
    *.json) python3 - "$1" "$2" <<'PY'
import json, sys
p, root = sys.argv[1], sys.argv[2]
txt = open(p).read().replace(root, "<OUT>")
def strip(v):
    if isinstance(v, dict):
        return {k: ([o.replace(root, "<OUT>") for o in x] if k == "outputs" else strip(x))
                for k, x in v.items() if k not in ("seconds_read", "seconds_filter")}
    if isinstance(v, list):
        return [strip(x) for x in v]
    return v
try:
    print(json.dumps(strip(json.loads(txt)), indent=1))  # keeps key order
except ValueError:
    print(txt)
PY
    ;;
    # Paths built from CARGO_MANIFEST_DIR (default scenarios) depend on where
    # and in which crate the binary was built; run timings are not outputs.
    *.stderr|*.stdout|*.toml|*.html|*.csv) sed -E -e 's#[^ ]*/crates/[a-z]+/\.\./\.\./scenarios/#<REPO>/scenarios/#g' \
      -e "s#$2#<OUT>#g" -e 's/[0-9.]* s -> /T s -> /' \
      -e 's#(seconds_(read|filter)</td><td><code>)[0-9.e-]+#\1T#g' "$1" ;;
    *) cat "$1" ;;
  esac
}
fail=0; n=0
while IFS= read -r f; do
  n=$((n+1))
  a="$REF/$f"; b="$OUT/$f"
  if [ ! -e "$b" ]; then echo "MISSING $f"; fail=1; continue; fi
  case "$f" in
    *.json|*.stderr|*.stdout|*.toml|*.html|*.csv)
      if ! cmp -s <(norm "$a" "$REF") <(norm "$b" "$OUT"); then echo "DIFFER  $f"; diff <(norm "$a" "$REF") <(norm "$b" "$OUT") | head -5; fail=1; fi ;;
    *) if ! cmp -s "$a" "$b"; then echo "DIFFER  $f"; fail=1; fi ;;
  esac
done < <(cd "$REF" && find . -type f ! -path './ref_bin/*' | sed 's#^\./##' | sort)
extra=$(cd "$OUT" && find . -type f | sed 's#^\./##' | sort | comm -13 <(cd "$REF" && find . -type f ! -path "./ref_bin/*" | sed 's#^\./##' | sort) -)
[ -n "$extra" ] && { echo "EXTRA files: $extra"; fail=1; }
[ $fail = 0 ] && echo "ALL $n FILES IDENTICAL" || echo "DIFFERENCES FOUND"
exit $fail
