#!/usr/bin/env bash
# Browser check of the navfuse report (issue 9): build navfuse, write reports,
# load each in headless Chromium from disk, screenshot it, and check that every
# plot rendered with its expected series count and that no script error was
# logged (tools/browser_check/check.py). Exits non-zero on any problem.
#
# Reports checked:
#   1. the synthetic fixture run (navfuse report --fixture), always;
#   2. the demo's report (navfuse demo --out DIR writes DIR/report/index.html
#      by default; older binaries needed --report, which is still accepted);
#   3. the drive_0708 outage run (navfuse kf-gins's ESKF and KF-GINS's result vs
#      truth), from $NAVFUSE_DATA
#      (default ../shared/data); required unless NAVFUSE_BROWSER_SKIP_REAL=1.
# Needs Debian's chromium: apt-get install -y chromium
set -euo pipefail
cd "$(dirname "$0")/../.."
OUT=target/browser_check
rm -rf "$OUT"
mkdir -p "$OUT"
cargo build --release -p navfuse
NF=target/release/navfuse
CHECK="python3 tools/browser_check/check.py"

echo "== browser check: synthetic fixture report"
$NF report "$OUT/fixture" --fixture --quiet
$CHECK "$OUT/fixture/report/index.html" --min-plots 19 --screenshot "$OUT/fixture.png"

if $NF demo --help 2>/dev/null | grep -q -- "--report"; then
  echo "== browser check: demo report"
  if $NF demo --out "$OUT/demo" --report >/dev/null 2>"$OUT/demo.log"; then
    $CHECK "$OUT/demo/report/index.html" --min-plots 5 --screenshot "$OUT/demo.png"
  else
    echo "navfuse demo failed (see $OUT/demo.log):" >&2; cat "$OUT/demo.log" >&2; exit 1
  fi
fi

if [ "${NAVFUSE_BROWSER_SKIP_REAL:-0}" != 1 ]; then
  echo "== browser check: drive_0708 outage report"
  D="${NAVFUSE_DATA:-../shared/data}/drive_0708/kfgins"
  for f in kfgins_result_outage_10hz.nav truth.nav gnss_outage.txt kf-gins_outage.yaml; do
    [ -f "$D/$f" ] || { echo "browser check: missing $D/$f (set NAVFUSE_DATA or NAVFUSE_BROWSER_SKIP_REAL=1)" >&2; exit 1; }
  done
  mkdir -p "$OUT/drive_0708/eskf"
  # navfuse's ESKF on KF-GINS's own outage configuration, beside KF-GINS's result.
  $NF kf-gins "$D/kf-gins_outage.yaml" --output "$OUT/drive_0708/eskf"
  $NF report "$OUT/drive_0708" --title "drive_0708 outage run: navfuse ESKF vs KF-GINS" \
    --solution "KF-GINS=$D/kfgins_result_outage_10hz.nav" \
    --kfgins-output "navfuse ESKF=$OUT/drive_0708/eskf" \
    --truth "$D/truth.nav" --fixes "$D/gnss_outage.txt" \
    --lever-arm 0,-0.05,0 --outages 120,90,30,243262 --quiet
  $CHECK "$OUT/drive_0708/report/index.html" --min-plots 8 --screenshot "$OUT/drive_0708.png"
fi
echo "== browser check: all reports ok (screenshots in $OUT)"
