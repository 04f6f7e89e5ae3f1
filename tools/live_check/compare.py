#!/usr/bin/env python3
"""Compare two solution files epoch by epoch (matched on t to 1 µs): navfuse
JSON lines (`navfuse live`), or KF-GINS .nav (`navfuse kf-gins`, time of
week in column 2): count matched / only-in-one, max horizontal and vertical
position difference [m]. Exit 1 if any matched epoch differs by more than
the tolerance or if the live file misses epochs of the reference."""
import json, math, sys

ref_path, live_path, tol = sys.argv[1], sys.argv[2], float(sys.argv[3])

def load(p):
    d = {}
    with open(p) as f:
        for line in f:
            if p.endswith(".nav"):
                c = line.split()
                o = {"t": float(c[1]), "lat": float(c[2]), "lon": float(c[3]), "h": float(c[4])}
            else:
                o = json.loads(line)
            d[round(o["t"] * 1e6)] = o
    return d

ref, live = load(ref_path), load(live_path)
common = sorted(set(ref) & set(live))
R = 6378137.0
dh_max = dv_max = 0.0
for k in common:
    a, b = ref[k], live[k]
    dn = math.radians(b["lat"] - a["lat"]) * R
    de = math.radians(b["lon"] - a["lon"]) * R * math.cos(math.radians(a["lat"]))
    dh_max = max(dh_max, math.hypot(dn, de))
    dv_max = max(dv_max, abs(b["h"] - a["h"]))
only_ref, only_live = len(set(ref) - set(live)), len(set(live) - set(ref))
print(f"compare: {len(common)} common epochs, {only_ref} only in reference, "
      f"{only_live} only in live; max |dH| = {dh_max*1e3:.4f} mm, max |dV| = {dv_max*1e3:.4f} mm "
      f"(tolerance {tol*1e3:.1f} mm)")
ok = len(common) > 0 and only_ref == 0 and only_live == 0 and dh_max <= tol and dv_max <= tol
sys.exit(0 if ok else 1)
