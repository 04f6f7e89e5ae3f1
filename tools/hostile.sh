#!/usr/bin/env bash
# Hostile inputs against every batch command (convert, run, kf-gins, eval,
# baseline, spp, allan) and live: truncated file, binary garbage, a 10 MB single line, a
# 1 GB file without a newline (sparse), an empty file, the wrong format for
# the extension, NaN/inf values, time going backwards, duplicate stamps.
# For each: exit code, the first line of the message, max RSS
# (/usr/bin/time -v) and the outputs left behind. Writes docs/hostile.md.
#
#   tools/hostile.sh [NAVFUSE_BINARY]      (default target/release/navfuse)
#   ONLY="live eval" tools/hostile.sh      (those sections; rows appended)
#
# Needs /usr/bin/time (apt-get install time) and $NAVFUSE_DATA (default
# ../shared/data) for the good halves of each case (drive_0708, GEONET RINEX).
# Targets: no panic (exit 70/101), no hang (timeout 120 s), max RSS ≤ 64 MiB
# for the 1 GB case, no output left by a failed command.
set -u
only=${ONLY:-all}
want() { [ "$only" = all ] || [[ " $only " == *" $1 "* ]]; }
here=$(cd "$(dirname "$0")/.." && pwd)
bin=${1:-$here/target/release/navfuse}
bin=$(cd "$(dirname "$bin")" && pwd)/$(basename "$bin")
data=${NAVFUSE_DATA:-$here/../shared/data}
data=$(cd "$data" && pwd)
K=$data/drive_0708/kfgins
R=$data/gnss/rinex
[ -x /usr/bin/time ] || { echo "needs /usr/bin/time (apt-get install -y time)"; exit 1; }
[ -f "$K/imu.txt" ] || { echo "no data at $data"; exit 1; }
work=$(mktemp -d /tmp/navfuse_hostile.XXXXXX)
trap 'rm -rf "$work"' EXIT
cd "$work"

# Good inputs: the first 300 s of the drive (fast runs), whole files else.
head -n 30000 "$K/imu.txt" > good_imu.txt
cp "$K/gnss_full.txt" good_gnss.txt
head -n 3000 "$K/kfgins_result_outage_10hz.nav" > good.nav
head -n 2000 "$data/drive_0708/gnss_1934_sf.pos" > good.pos

# make_variants GOOD EXT WRONG: hostile copies of GOOD named h_<case>.EXT.
# WRONG is a file of another format given the same extension.
make_variants() {
    local good=$1 ext=$2 wrong=$3 n
    n=$(wc -l < "$good")
    head -c $(( $(stat -c %s "$good") / 2 + 7 )) "$good" > "h_truncated.$ext"
    head -c 1048576 /dev/urandom > "h_garbage.$ext"
    { head -n 5 "$good"; head -c 10000000 /dev/zero | tr '\0' '7'; echo; tail -n +6 "$good"; } > "h_line10MB.$ext"
    rm -f "h_1GB_nonewline.$ext"; truncate -s 1G "h_1GB_nonewline.$ext"
    : > "h_empty.$ext"
    cp "$wrong" "h_wrongformat.$ext"
    # NaN and inf in the numbers of two lines in the middle.
    awk -v a=$((n / 2)) -v b=$((n / 2 + 3)) '{ if (NR == a) { $3 = "nan" } if (NR == b) { $4 = "inf" } print }' "$good" > "h_naninf.$ext"
    # A block of 20 lines moved back: time goes backwards.
    awk -v a=$((n / 2)) '{ l[NR] = $0 } END { for (i = 1; i <= NR; i++) { if (i >= a && i < a + 20) continue; print l[i]; if (i == a + 40) for (j = a; j < a + 20; j++) print l[j] } }' "$good" > "h_backwards.$ext"
    # Every line of a stretch written twice: duplicate stamps.
    awk -v a=$((n / 2)) '{ print; if (NR >= a && NR < a + 20) print }' "$good" > "h_duplicates.$ext"
}

cases="truncated garbage line10MB 1GB_nonewline empty wrongformat naninf backwards duplicates"
out_md=$here/docs/hostile.md
rows=()

# run_case CMD CASE OUTDIR -- ARGS...: run, record a table row.
run_case() {
    local cmd=$1 case=$2 outdir=$3
    shift 4
    rm -rf "$outdir"; mkdir -p "$outdir"
    timeout 120 /usr/bin/time -v -o time.txt "$bin" "$@" < "${STDIN:-/dev/null}" > stdout.txt 2> stderr.txt
    local rc=$?
    local rss; rss=$(awk -F': ' '/Maximum resident/ { printf "%.1f", $2 / 1024 }' time.txt)
    # The error line on failure (warnings may precede it), else the first line.
    local msg
    if [ $rc -ne 0 ] && grep -q '^navfuse: ' stderr.txt; then
        msg=$(grep '^navfuse: ' stderr.txt | head -n 1)
    else
        msg=$(head -n 1 stderr.txt)
    fi
    # live ends with a summary: its IMU accounting line says the most.
    if [ "$cmd" = live ] && grep -q 'IMU input' stderr.txt; then
        msg=$(grep -m1 'IMU input' stderr.txt | sed 's/^ *//')
    fi
    msg=$(echo "$msg" | cut -c1-150 | sed 's/|/\\|/g')
    [ -z "$msg" ] && msg="(stdout) $(head -n 1 stdout.txt | cut -c1-120 | sed 's/|/\\|/g')"
    local left; left=$(cd "$outdir" && find . -type f | sed 's|^\./||' | sort | tr '\n' ' ')
    [ -z "$left" ] && left="none"
    local verdict=ok
    if [ $rc -eq 124 ]; then verdict="HANG"; elif [ $rc -eq 70 ] || [ $rc -eq 101 ] || grep -q panicked stderr.txt; then verdict="PANIC"; fi
    if [[ "$case" == *1GB_nonewline ]] && [ "${rss%.*}" -gt 64 ]; then verdict="$verdict RSS>64MiB"; fi
    if [ $rc -ne 0 ] && [ "$left" != none ]; then verdict="$verdict PARTIAL-OUTPUT"; fi
    if echo "$left" | grep -q navfuse-tmp; then verdict="$verdict TEMP-LEFT"; fi
    rows+=("| $cmd | $case | $rc | \`$msg\` | $rss | $left | $verdict |")
    echo "$cmd $case rc=$rc rss=${rss}MiB left=[$left] $verdict"
}

# convert: an RTKLIB .pos → CSV.
if want convert; then
mkdir -p convert && cd convert
make_variants ../good.pos pos ../good.nav
for c in $cases; do run_case convert "$c" out -- convert "h_$c.pos" out/out.csv; done
cd ..
fi

# kf-gins: the drive's YAML with the IMU file replaced.
if want kfgins; then
mkdir -p kfgins && cd kfgins
make_variants ../good_imu.txt txt ../good_gnss.txt
for c in $cases; do
    sed -e "s|^imupath:.*|imupath: \"h_$c.txt\"|" -e "s|^gnsspath:.*|gnsspath: \"../good_gnss.txt\"|" \
        -e "s|^outputpath:.*|outputpath: \"out\"|" "$K/kf-gins_outage.yaml" > "k_$c.yaml"
    run_case kf-gins "$c" out -- kf-gins "k_$c.yaml" --enhanced
done
cd ..
fi

# run: a TOML on the same IMU variants (KF-GINS text) and GNSS.
if want run; then
mkdir -p run && cd run
make_variants ../good_imu.txt txt ../good_gnss.txt
for c in $cases; do
    printf 'output = "out"\n[input]\nimu = "h_%s.txt"\nimu_format = "kf-gins"\ngnss = "../good_gnss.txt"\ngnss_format = "kf-gins"\n[filter]\nplatform = "car"\n' "$c" > "r_$c.toml"
    run_case run "$c" out -- run "r_$c.toml"
done
cd ..
fi

# eval: a KF-GINS .nav solution against the drive's truth.
if want eval; then
mkdir -p eval && cd eval
make_variants ../good.nav nav ../good.pos
for c in $cases; do run_case eval "$c" out -- eval "h_$c.nav" --truth "$K/truth.nav" --csv out/errors.csv --json out/eval.json; done
cd ..
fi

# allan: a KF-GINS IMU log.
if want allan; then
mkdir -p allan && cd allan
make_variants ../good_imu.txt txt ../good_gnss.txt
for c in $cases; do run_case allan "$c" out -- allan "h_$c.txt" --format kfgins --out out; done
cd ..
fi

# baseline: the GEONET rover observation file replaced.
if want baseline; then
mkdir -p baseline && cd baseline
head -n 4000 "$R/07590920.05o" > good.obs
make_variants good.obs 05o "$R/07590920.05n"
for c in $cases; do run_case baseline "$c" out -- baseline --rover "h_$c.05o" --base "$R/30400920.05o" --nav "$R/07590920.05n" --out out/b.csv; done
cd ..
fi

# spp: the GEONET observation file replaced, then the navigation file.
if want spp; then
mkdir -p spp && cd spp
head -n 4000 "$R/07590920.05o" > good.obs
make_variants good.obs 05o "$R/07590920.05n"
for c in $cases; do run_case spp "$c" out -- spp "h_$c.05o" --nav "$R/07590920.05n" out/s.pos; done
cp "$R/07590920.05n" good.nav
make_variants good.nav 05n "$R/07590920.05o"
for c in $cases; do run_case spp "nav-$c" out -- spp "$R/07590920.05o" --nav "h_$c.05n" out/s.pos; done
cd ..
fi

# live: the IMU stream on stdin (KF-GINS lines), no GNSS; the solution
# stream is written as it goes (a live log), the summary at the end.
if want live; then
mkdir -p live && cd live
make_variants ../good_imu.txt txt ../good_gnss.txt
for c in $cases; do
    STDIN="h_$c.txt" run_case live "$c" out -- live --platform car --imu - --gnss none --gps-week 2374 --out out/sol.jsonl --summary-json out/summary.json
done
cd ..
fi

if [ "$only" != all ]; then printf '%s\n' "${rows[@]}" >> "$out_md"; echo "appended to $out_md"; exit 0; fi
{
    echo "# Hostile inputs"
    echo
    echo "Generated by \`tools/hostile.sh\` ($(date -u +%Y-%m-%d), $(cd "$here" && git rev-parse --short HEAD 2>/dev/null))."
    echo "Each command gets one hostile input (the others good, from drive_0708 / GEONET):"
    echo "the first half of the file (cut mid-line), 1 MiB of random bytes, a 10 MB line"
    echo "among good lines, a 1 GB sparse file of NUL bytes without a newline, an empty"
    echo "file, another format under the same extension, \`nan\`/\`inf\` in two lines, a"
    echo "block of 20 lines moved back in time, 20 lines written twice."
    echo "Exit codes: docs/exit-codes.md. RSS: maximum resident set size from"
    echo "\`/usr/bin/time -v\`, MiB. \"left\": files in the output folder after the command"
    echo "(a failed command must leave none). Verdict \`ok\` = no panic, no hang, no"
    echo "partial output, ≤ 64 MiB for the 1 GB case."
    echo
    echo "| command | input | exit | first line of the message | max RSS MiB | left | verdict |"
    echo "|---|---|---|---|---|---|---|"
    printf '%s\n' "${rows[@]}"
} > "$out_md"
echo "wrote $out_md"
