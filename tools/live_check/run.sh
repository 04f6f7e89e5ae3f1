#!/usr/bin/env bash
# End-to-end live test (issue 8, must-show 1): gpsfake replays an NMEA log
# made from drive_0708's RTK .pos into a gpsd on loopback while the drive's
# IMU (KF-GINS text) streams on stdin, paced to the GNSS replay; `navfuse
# live` fuses them. Its solutions are compared with a batch run of the same
# estimator over the same two files (same solutions within 1 mm, every
# epoch present); latency p50/p99 and record counts come from the summary.
#
# Env: NAVFUSE_DATA (default ../shared/data), LIVE_SPEED (replay speed-up,
# default 5), LIVE_GPSD_PORT (default 2947), LIVE_ESTIMATOR (default hold),
# LIVE_OUT (default target/live_check). Loopback only.
set -euo pipefail
cd "$(dirname "$0")/../.."
DATA=${NAVFUSE_DATA:-../shared/data}
D=$DATA/drive_0708
SPEED=${LIVE_SPEED:-5}
PORT=${LIVE_GPSD_PORT:-2947}
EST=${LIVE_ESTIMATOR:-hold}
OUT=${LIVE_OUT:-target/live_check}
WEEK=2374
mkdir -p "$OUT"

if ! command -v gpsfake >/dev/null || ! command -v gpsd >/dev/null; then
  SUDO=; [ "$(id -u)" = 0 ] || SUDO=sudo
  $SUDO apt-get install -y --no-install-recommends gpsd gpsd-clients \
    || { $SUDO apt-get update && $SUDO apt-get install -y --no-install-recommends gpsd gpsd-clients; }
fi
cargo build --release -q -p navfuse
BIN=target/release/navfuse

echo "== NMEA log from $D/gnss_1934_sf.pos"
$BIN convert "$D/gnss_1934_sf.pos" "$OUT/gnss_body.nmea"
# A receiver-style preamble (text + one ZDA, one second before the first
# epoch) so gpsd has identified the device and knows the date before the
# first fix; the same file feeds both the batch and the live run.
# Cycle per sentence: 3 sentences (GGA, RMC, GST) per 0.25 s epoch.
CYCLE=$(python3 -c "print(0.25 / 3 / $SPEED)")
python3 - "$OUT/gnss_body.nmea" "$OUT/gnss.nmea" "$CYCLE" <<'PY'
import math, sys
body = open(sys.argv[1]).read()
first = body.split(",", 2)[1]  # hhmmss.sss of the first GGA
ddmmyy = next(l for l in body.splitlines() if "RMC" in l).split(",")[9]
def cs(s):
    x = 0
    for c in s.encode():
        x ^= c
    return "$%s*%02X\r\n" % (s, x)
sod = int(first[:2]) * 3600 + int(first[2:4]) * 60 + float(first[4:]) - 1.0
h, m, s = int(sod // 3600), int(sod % 3600 // 60), sod % 60
# ~2 s of wall-clock replay: gpsd needs about 1 s to identify a new device.
n = max(30, math.ceil(2.0 / float(sys.argv[3])))
pre = "".join(cs("GNTXT,01,01,02,navfuse live_check preamble %d" % k) for k in range(n))
pre += cs("GNZDA,%02d%02d%06.3f,%s,%s,20%s,00,00" % (h, m, s, ddmmyy[:2], ddmmyy[2:4], ddmmyy[4:]))
open(sys.argv[2], "w").write(pre + body)
PY

echo "== batch reference: same estimator, same files"
$BIN live --estimator "$EST" --gnss "nmea:$OUT/gnss.nmea" --imu "$D/kfgins/imu.txt" --gps-week $WEEK \
  --idle 0.2 --max-wait 1e9 --out "$OUT/batch.jsonl" --summary-json "$OUT/batch_summary.json"

echo "== live: gpsfake -> gpsd 127.0.0.1:$PORT, IMU on stdin at ${SPEED}x"
if (exec 3<>/dev/tcp/127.0.0.1/$PORT) 2>/dev/null; then
  echo "port $PORT is busy (a gpsd running?); set LIVE_GPSD_PORT" >&2; exit 1
fi
gpsfake -1 -q -P "$PORT" -c "$CYCLE" "$OUT/gnss.nmea" > "$OUT/gpsfake.log" 2>&1 &
GF=$!
trap 'kill $GF 2>/dev/null || true' EXIT
for _ in $(seq 50); do (exec 3<>/dev/tcp/127.0.0.1/$PORT) 2>/dev/null && break; sleep 0.1; done
python3 tools/live_check/pace.py --gpsd 127.0.0.1:$PORT "$D/kfgins/imu.txt" "$SPEED" \
  | $BIN live --estimator "$EST" --gnss gpsd:127.0.0.1:$PORT --imu - --gps-week $WEEK \
      --max-wait 10 --out "$OUT/live.jsonl" --summary-json "$OUT/live_summary.json"

echo "== compare live vs batch (1 mm)"
python3 tools/live_check/compare.py "$OUT/batch.jsonl" "$OUT/live.jsonl" 0.001
python3 - "$OUT/live_summary.json" <<'PY'
import json, sys
s = json.load(open(sys.argv[1]))
print("live: latency p50 %.3f ms, p99 %.3f ms, max %.3f ms over %d samples" %
      (s["latency_p50_ms"], s["latency_p99_ms"], s["latency_max_ms"], s["latency_n"]))
print("live: IMU", s["imu"], "| GNSS (gpsd)", s["gnss"])
print("live: solutions %d, released by timeout IMU %d GNSS %d, late IMU %d GNSS %d" %
      (s["solutions"], s["imu_released_by_timeout"], s["gnss_released_by_timeout"], s["imu_late"], s["gnss_late"]))
bad = s["imu_released_by_timeout"] + s["gnss_released_by_timeout"] + s["imu_late"] + s["gnss_late"]
sys.exit(1 if bad else 0)
PY
echo "live_check: OK"
