#!/usr/bin/env python3
"""Stream a KF-GINS IMU text file to stdout, line-buffered, at `speed` x real
time by its time-of-week column: the stand-in for a live IMU.

With `--gpsd HOST:PORT` the IMU shares the clock of the GNSS replay, as a
real receiver and IMU share real time: a thread watches gpsd's TPV reports
and each one re-anchors the clock (TPV time T, UTC -> GPS time of week with
GPS-UTC = 18 s, valid 2017-2026+, arriving at wall time w); the IMU line of
time of week t is written at w + (t - T) / speed. gpsfake runs a little
slower than its nominal cycle, and without re-anchoring the IMU would run
ahead of the GNSS by seconds at the end of the drive."""
import datetime, json, socket, sys, threading, time

args = sys.argv[1:]
gpsd = None
if args and args[0] == "--gpsd":
    gpsd, args = args[1], args[2:]
path, speed = args[0], float(args[1])

anchor = [None]  # (T, wall)
lock = threading.Lock()

def watch():
    host, port = gpsd.rsplit(":", 1)
    s = socket.create_connection((host, int(port)))
    s.sendall(b'?WATCH={"enable":true,"json":true};\n')
    for line in s.makefile("r"):
        try:
            o = json.loads(line)
        except ValueError:
            continue
        if o.get("class") == "TPV" and "time" in o:
            w = time.monotonic()
            dt = datetime.datetime.strptime(o["time"], "%Y-%m-%dT%H:%M:%S.%fZ")
            gps = (dt - datetime.datetime(1980, 1, 6)).total_seconds() + 18.0
            with lock:
                anchor[0] = (gps % 604800.0, w)

if gpsd:
    time.sleep(0.5)  # let `navfuse live` connect first: gpsfake starts feeding on the first watcher
    threading.Thread(target=watch, daemon=True).start()
    while anchor[0] is None:
        time.sleep(0.005)
else:
    anchor[0] = (None, time.monotonic())

out = sys.stdout
with open(path) as f:
    for line in f:
        tok = line.split(None, 1)
        try:
            tow = float(tok[0])
        except (ValueError, IndexError):
            tow = None
        while tow is not None:
            with lock:
                T, w = anchor[0]
            if T is None:
                anchor[0] = (tow, w)
                continue
            wait = w + (tow - T) / speed - time.monotonic()
            if wait <= 0:
                break
            time.sleep(min(wait, 0.005))
        out.write(line)
        out.flush()
