#!/usr/bin/env bash
# Output-neutrality check for refactors (e.g. the move of the run pipeline
# into navfuse-pipeline): every output file and message must stay identical.
# Usage: tools/move_check.sh NAVFUSE_BIN OUT_DIR [REF_DIR]
#   1. with the old binary:  tools/move_check.sh old/navfuse /tmp/ref
#   2. with the new binary:  tools/move_check.sh target/release/navfuse /tmp/new /tmp/ref
# Runs kf-gins (full; outage --enhanced --smooth), run (ESKF with smoothing and
# extra formats; pf-lc), demo and a set of bad configs/options with
# NAVFUSE_BIN into OUT_DIR; with REF_DIR, compares every file (and each
# command's stderr) against REF_DIR byte for byte. Data: $NAVFUSE_DATA
# (default ../shared/data relative to the repo).
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
run demo           "$BIN" demo --out "$OUT/demo"
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
[ -z "$REF" ] && exit 0
norm() { # file, its root dir -> normalised text on stdout
  case "$1" in
    *.json) python3 - "$1" "$2" <<'PY'
import json, sys
p, root = sys.argv[1], sys.argv[2]
txt = open(p).read()
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
    *.stderr|*.toml) sed -e "s#$2#<OUT>#g" -e 's/[0-9.]* s -> /T s -> /' "$1" ;;
    *) cat "$1" ;;
  esac
}
fail=0; n=0
while IFS= read -r f; do
  n=$((n+1))
  a="$REF/$f"; b="$OUT/$f"
  if [ ! -e "$b" ]; then echo "MISSING $f"; fail=1; continue; fi
  case "$f" in
    *.json|*.stderr|*.toml)
      if ! cmp -s <(norm "$a" "$REF") <(norm "$b" "$OUT"); then echo "DIFFER  $f"; diff <(norm "$a" "$REF") <(norm "$b" "$OUT") | head -5; fail=1; fi ;;
    *) if ! cmp -s "$a" "$b"; then echo "DIFFER  $f"; fail=1; fi ;;
  esac
done < <(cd "$REF" && find . -type f ! -path './ref_bin/*' | sed 's#^\./##' | sort)
extra=$(cd "$OUT" && find . -type f | sed 's#^\./##' | sort | comm -13 <(cd "$REF" && find . -type f ! -path "./ref_bin/*" | sed 's#^\./##' | sort) -)
[ -n "$extra" ] && { echo "EXTRA files: $extra"; fail=1; }
[ $fail = 0 ] && echo "ALL $n FILES IDENTICAL" || echo "DIFFERENCES FOUND"
exit $fail
