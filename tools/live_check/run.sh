#!/usr/bin/env bash
# End-to-end live test (issue 8, must-show 1): gpsfake replays an NMEA log
# made from drive_0708's GNSS into a gpsd on loopback while the drive's IMU
# (KF-GINS text) streams on stdin, paced to the GNSS replay; `navfuse live`
# fuses them, and its solutions must equal the batch run's within 1 mm with
# every epoch present and no event arriving too late for its place.
#
#  A. ESKF: NMEA from kfgins/gnss_full.txt (1 Hz); batch = `navfuse kf-gins
#     kf-gins_full.yaml`; live = `navfuse live --estimator eskf
#     --kfgins-config kf-gins_full.yaml` (same model and initial state).
#  B. Test estimator `hold` (last fix at every IMU sample, the sharpest check
#     of event order): NMEA from gnss_1934_sf.pos (4 Hz, 2197 epochs); batch
#     = `navfuse live` over the NMEA file.
# Latency p50/p99 and record counts are printed from the live summaries.
#
# Env: NAVFUSE_DATA (default ../shared/data), LIVE_SPEED (replay speed-up,
# default 5), LIVE_GPSD_PORT (default 2947), LIVE_OUT (default
# target/live_check). Loopback only.
set -euo pipefail
cd "$(dirname "$0")/../.."
DATA=${NAVFUSE_DATA:-../shared/data}
D=$DATA/drive_0708
SPEED=${LIVE_SPEED:-5}
PORT=${LIVE_GPSD_PORT:-2947}
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

# preamble BODY OUT CYCLE: a receiver-style preamble (text lines for ~2 s of
# replay, then one ZDA one second before the first epoch) so gpsd has
# identified the device and knows the date before the first fix. The same
# file feeds both the batch and the live run.
preamble() {
python3 - "$1" "$2" "$3" <<'PY'
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
n = max(30, math.ceil(2.0 / float(sys.argv[3])))
pre = "".join(cs("GNTXT,01,01,02,navfuse live_check preamble %d" % k) for k in range(n))
pre += cs("GNZDA,%02d%02d%06.3f,%s,%s,20%s,00,00" % (h, m, s, ddmmyy[:2], ddmmyy[2:4], ddmmyy[4:]))
open(sys.argv[2], "w").write(pre + body)
PY
}

# live NAME NMEA EPOCH_S ARGS...: replay NMEA via gpsfake, stream the IMU, run navfuse live.
live() {
  local name=$1 nmea=$2 epoch=$3; shift 3
  if (exec 3<>/dev/tcp/127.0.0.1/$PORT) 2>/dev/null; then
    echo "port $PORT is busy (a gpsd running?); set LIVE_GPSD_PORT" >&2; exit 1
  fi
  local cycle; cycle=$(python3 -c "print($epoch / 3 / $SPEED)")  # GGA, RMC, GST per epoch
  gpsfake -1 -q -P "$PORT" -c "$cycle" "$nmea" > "$OUT/gpsfake_$name.log" 2>&1 &
  local gf=$!
  for _ in $(seq 50); do (exec 3<>/dev/tcp/127.0.0.1/$PORT) 2>/dev/null && break; sleep 0.1; done
  python3 tools/live_check/pace.py --gpsd 127.0.0.1:$PORT "$D/kfgins/imu.txt" "$SPEED" \
    | $BIN live "$@" --gnss gpsd:127.0.0.1:$PORT --imu - --gps-week $WEEK \
        --max-wait 2 --out "$OUT/live_$name.jsonl" --summary-json "$OUT/live_$name.json"
  # gpsfake -1 does not exit by itself after the log (its gpsd stays up).
  kill $gf 2>/dev/null || true; sleep 1; kill -9 $gf 2>/dev/null || true
}

summary() {
python3 - "$1" <<'PY'
import json, sys
s = json.load(open(sys.argv[1]))
print("  latency p50 %.3f ms, p99 %.3f ms, max %.3f ms over %d samples" %
      (s["latency_p50_ms"], s["latency_p99_ms"], s["latency_max_ms"], s["latency_n"]))
print("  IMU", s["imu"], "| GNSS", s["gnss_source"], s["gnss"])
print("  solutions %d; released by timeout IMU %d GNSS %d; late IMU %d GNSS %d" %
      (s["solutions"], s["imu_released_by_timeout"], s["gnss_released_by_timeout"], s["imu_late"], s["gnss_late"]))
# A release by timeout is harmless unless a fix then arrives late (it would
# have changed the event order): late events fail the check, and the
# comparison above catches any difference. The IMU after the last fix of the
# log always waits max-wait (gpsd stays up, so the GNSS never ends).
sys.exit(1 if s["imu_late"] + s["gnss_late"] else 0)
PY
}

echo "== A. ESKF (kf-gins_full.yaml), GNSS 1 Hz from kfgins/gnss_full.txt"
CFG=$D/kfgins/kf-gins_full.yaml
$BIN convert "$D/kfgins/gnss_full.txt" "$OUT/gnss1hz_body.nmea" --from kfgins-gnss --gps-week $WEEK
preamble "$OUT/gnss1hz_body.nmea" "$OUT/gnss1hz.nmea" "$(python3 -c "print(1.0 / 3 / $SPEED)")"
$BIN kf-gins "$CFG" --output "$OUT/kfgins_batch" --verbose
$BIN live --estimator eskf --kfgins-config "$CFG" --gnss "nmea:$OUT/gnss1hz.nmea" --imu "$D/kfgins/imu.txt" \
  --gps-week $WEEK --idle 0.2 --max-wait 1e9 --out "$OUT/file_eskf.jsonl" --summary-json "$OUT/file_eskf.json"
echo "-- navfuse live over the NMEA file vs navfuse kf-gins"
python3 tools/live_check/compare.py "$OUT/kfgins_batch/KF_GINS_Navresult.nav" "$OUT/file_eskf.jsonl" 0.001
live eskf "$OUT/gnss1hz.nmea" 1.0 --estimator eskf --kfgins-config "$CFG"
echo "-- navfuse live via gpsd vs navfuse kf-gins"
python3 tools/live_check/compare.py "$OUT/kfgins_batch/KF_GINS_Navresult.nav" "$OUT/live_eskf.jsonl" 0.001
summary "$OUT/live_eskf.json"

echo "== B. test estimator 'hold', GNSS 4 Hz from gnss_1934_sf.pos"
$BIN convert "$D/gnss_1934_sf.pos" "$OUT/gnss4hz_body.nmea"
preamble "$OUT/gnss4hz_body.nmea" "$OUT/gnss4hz.nmea" "$(python3 -c "print(0.25 / 3 / $SPEED)")"
$BIN live --estimator hold --gnss "nmea:$OUT/gnss4hz.nmea" --imu "$D/kfgins/imu.txt" --gps-week $WEEK \
  --idle 0.2 --max-wait 1e9 --out "$OUT/file_hold.jsonl" --summary-json "$OUT/file_hold.json"
live hold "$OUT/gnss4hz.nmea" 0.25 --estimator hold
echo "-- navfuse live via gpsd vs navfuse live over the NMEA file"
python3 tools/live_check/compare.py "$OUT/file_hold.jsonl" "$OUT/live_hold.jsonl" 0.001
summary "$OUT/live_hold.json"
echo "live_check: OK"
