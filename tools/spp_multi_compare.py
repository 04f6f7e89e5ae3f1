#!/usr/bin/env python3
"""Epoch-by-epoch comparison of `navfuse spp` (lat/lon/height .pos) and RTKLIB
`rnx2rtkp` (ECEF .pos, GPST week/TOW) on the simulated multi-GNSS log, and of
both against the simulator's truth (truth.csv: receiver tag, ECEF, clock bias).
Usage: spp_multi_compare.py navfuse.pos rtklib.pos truth.csv"""
import math
import sys
from datetime import datetime, timezone

A, F = 6378137.0, 1 / 298.257223563
E2 = F * (2 - F)
GPS0 = datetime(1980, 1, 6, tzinfo=timezone.utc)


def ecef(lat, lon, h):
    lat, lon = math.radians(lat), math.radians(lon)
    n = A / math.sqrt(1 - E2 * math.sin(lat) ** 2)
    return ((n + h) * math.cos(lat) * math.cos(lon), (n + h) * math.cos(lat) * math.sin(lon),
            (n * (1 - E2) + h) * math.sin(lat))


def key(t):
    return round(t * 1000)


def read_navfuse(p):
    out = {}
    for l in open(p):
        if l.startswith('%') or not l.strip():
            continue
        f = l.split()
        d = datetime.strptime(f[0] + ' ' + f[1][:15], '%Y/%m/%d %H:%M:%S.%f').replace(tzinfo=timezone.utc)
        out[key((d - GPS0).total_seconds())] = (ecef(float(f[2]), float(f[3]), float(f[4])), int(f[6]))
    return out


def read_rtklib(p):
    out = {}
    for l in open(p):
        if l.startswith('%') or not l.strip():
            continue
        f = l.split()
        t = int(f[0]) * 604800 + float(f[1])
        out[key(t)] = ((float(f[2]), float(f[3]), float(f[4])), int(f[6]))
    return out


def read_truth(p):
    out = {}
    for l in list(open(p))[1:]:
        tag, x, y, z, b = map(float, l.split(','))
        out[key(tag - b)] = (x, y, z)
    return out


def rms(v):
    return math.sqrt(sum(x * x for x in v) / len(v)) if v else float('nan')


def d3(a, b):
    return math.dist(a, b)


n, r, tr = read_navfuse(sys.argv[1]), read_rtklib(sys.argv[2]), read_truth(sys.argv[3])
common = sorted(set(n) & set(r))
diff = [d3(n[k][0], r[k][0]) for k in common]
en = [d3(n[k][0], tr[k]) for k in n if k in tr]
er = [d3(r[k][0], tr[k]) for k in r if k in tr]
print(f"epochs: navfuse {len(n)}, rnx2rtkp {len(r)}, common {len(common)}; "
      f"satellites used per epoch: navfuse {sum(v[1] for v in n.values()) / len(n):.2f}, "
      f"rnx2rtkp {sum(v[1] for v in r.values()) / len(r):.2f}")
print(f"navfuse - rnx2rtkp 3D: RMS {rms(diff):.3f} m, max {max(diff):.3f} m")
print(f"3D error vs truth: navfuse RMS {rms(en):.3f} m ({len(en)} epochs), rnx2rtkp RMS {rms(er):.3f} m ({len(er)} epochs)")
