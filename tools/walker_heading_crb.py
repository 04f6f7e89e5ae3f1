#!/usr/bin/env python3
"""Cramér–Rao bound of the walker's yaw error (issue 13, must-show 3).

How well can ANY estimator know a walker's heading over [30, 60] s after
the motion start, from 1 Hz GNSS velocity (+ positions for RTK), with an
ADIS16465-class IMU? Linearised error model, horizontal only:

    δv(t) = δv0 + ∫ [ J a(τ) δψ(τ) + C_bn(τ) b_a + g J θ ] dτ,
    δψ(τ) = ψ0 + b_z (τ − t0)

parameters ψ0 (yaw at the hand-over, prior σ 5° = one bank member),
b_z (z-gyro bias, prior σ 240°/h = the preset's turn-on σ), δv0 (σ_v),
b_a (body forward/right accelerometer bias, 25/3 mg), θ (tilt, 1°).
Causal: information from the epochs up to t. "smoothed": all epochs of
the 90 s run. Walks are drawn like crates/sim/src/platform/walker.rs
(1.0–1.5 m/s, 45 % straights of 3–15 strides, 40 % turns of 45–135° in
1–3 strides or 180° in 2–3, 15 % pauses of 2–10 s; the step motion
averages out within a stride and is left out).

Printed per case: the median σ at 30 s and 60 s, the window maximum, and
the mean over walks of P(|e| < 2°) at the worst epoch — an upper bound of
the pass share, which needs every epoch < 2°.

Usage: python3 tools/walker_heading_crb.py SEED N  (needs numpy)
"""
import numpy as np, sys
rng = np.random.default_rng(int(sys.argv[1]) if len(sys.argv) > 1 else 1)
DEG = np.pi/180
dt = 0.01
def walker(T=90.0):
    cad = rng.uniform(1.8, 2.0); stride = 2/cad
    off = rng.uniform(-30, 30)*DEG
    course = rng.uniform(-np.pi, np.pi); v = rng.uniform(1.0, 1.5)
    ts=[];cs=[];vs=[]; t=0.0
    def push(d, v1, turn):
        nonlocal t, course, v
        n = max(1, int(round(d/dt)))
        for i in range(n):
            a = (i+1)/n
            ts.append(t + (i+1)*dt); cs.append(course + turn*a); vs.append(v + (v1-v)*a)
        t += n*dt; course += turn; v = v1
    while t < T:
        if v < 1e-9:
            push(stride, rng.uniform(1.0,1.5), 0.0); continue
        u = rng.random()
        if u < 0.45:
            n = rng.integers(3, 16); s = rng.uniform(1.0,1.5) if rng.random()<0.5 else v
            push(n*stride, s, 0.0)
        elif u < 0.85:
            if rng.random() < 0.15: ang, n = np.pi, rng.integers(2,4)
            else: ang, n = rng.uniform(45,135)*DEG, rng.integers(1,4)
            push(n*stride, v, ang*(1 if rng.random()<0.5 else -1))
        else:
            push(stride, 0.0, 0.0); push(rng.uniform(2,10), 0.0, 0.0)
    ts=np.array(ts); cs=np.array(cs); vs=np.array(vs)
    vel = np.stack([vs*np.cos(cs), vs*np.sin(cs)],1)
    return ts, vel, cs + off   # body yaw = course + offset

def crb(ts, vel, yaw, sv, sp, t0=3.0, tw=(30,60), psd=5.0, tsd=1.0):
    # params: psi0, bz, dv0N, dv0E, baF, baR, thN, thE
    g = 9.81
    k0 = np.searchsorted(ts, t0)
    acc = np.gradient(vel, dt, axis=0)
    # sensitivities of the velocity error (2) to each parameter, integrated
    n = len(ts); S = np.zeros((n, 2, 8)); P = np.zeros((n,2,8))
    s = np.zeros((2,8)); p = np.zeros((2,8))
    J = np.array([[0,-1],[1,0]])
    for k in range(k0, n):
        tau = ts[k]-t0
        Ja = J @ acc[k]
        dsd = np.zeros((2,8))
        dsd[:,0] = Ja; dsd[:,1] = Ja*tau
        c, si = np.cos(yaw[k]), np.sin(yaw[k])
        dsd[:,4] = [c, si]; dsd[:,5] = [-si, c]
        dsd[:,6] = [0, g]; dsd[:,7] = [-g, 0]   # tilt error -> horizontal force error
        s = s + dsd*dt; p = p + s*dt
        S[k] = s; P[k] = p
    S[:, :, 2] = [1,0]; S[:, :, 3] = [0,1]
    # prior (information)
    prior_sd = np.array([psd*DEG, 240*DEG/3600, sv, sv, 25e-3/3*g, 25e-3/3*g, tsd*DEG, tsd*DEG])
    I = np.diag(1/prior_sd**2)
    out = []
    smooth = tw[1] < 0
    ep = np.where(np.abs((ts - np.round(ts))) < dt/2)[0]
    ep = ep[ts[ep] >= t0]
    j = 0
    for k in ep:
        H = S[k]; I = I + H.T @ H / sv**2
        if sp is not None:
            Hp = P[k].copy(); Hp[:, 2] = [ts[k]-t0, 0]; Hp[:, 3] = [0, ts[k]-t0]
            I = I + Hp.T @ Hp / sp**2
        if (not smooth) and tw[0] <= ts[k] <= tw[1]:
            C = np.linalg.inv(I); gv = np.zeros(8); gv[0]=1; gv[1]=ts[k]-t0
            out.append(np.sqrt(gv@C@gv)/DEG)
    if smooth:
        C = np.linalg.inv(I)
        for k in ep:
            if 30 <= ts[k] <= 60:
                gv = np.zeros(8); gv[0]=1; gv[1]=ts[k]-t0
                out.append(np.sqrt(gv@C@gv)/DEG)
    return np.array(out)

res = {'consumer': [], 'rtk': [], 'consumer_60s_from0': []}
N = int(sys.argv[2]) if len(sys.argv) > 2 else 200
from math import erf, sqrt
pp = {'consumer': [], 'rtk': [], 'rtk_oracle': [], 'consumer_smoothed': []}
res['consumer_smoothed']=[]
res['rtk_oracle']=[]
for i in range(N):
    ts, vel, yaw = walker()
    c = crb(ts, vel, yaw, 0.1, None); r = crb(ts, vel, yaw, 0.02, 0.02); o = crb(ts, vel, yaw, 0.02, 0.02, t0=0.01, psd=0.1, tsd=0.1)
    res['consumer'].append(c); res['rtk'].append(r); res['rtk_oracle'].append(o); cs = crb(ts, vel, yaw, 0.1, None, tw=(30,-1)); res['consumer_smoothed'].append(cs)
    # P(|e| < 2° at every epoch) lower bound ~ P at the worst epoch (errors strongly correlated)
    for name, x in (('consumer', c), ('rtk', r), ('rtk_oracle', o), ('consumer_smoothed', cs)):
        sm = x.max(); pp[name].append(erf(2/(sm*sqrt(2))))
for name in ('consumer','rtk','rtk_oracle','consumer_smoothed'):
    a = np.array([x.max() for x in res[name]]); m = np.array([x.mean() for x in res[name]])
    b30 = np.array([x[0] for x in res[name]]); b60 = np.array([x[-1] for x in res[name]])
    print(f"{name}: sigma_yaw over [30,60] s: at 30 s median {np.median(b30):.2f} deg, at 60 s median {np.median(b60):.2f}; window max: median {np.median(a):.2f}, p10 {np.percentile(a,10):.2f}, p90 {np.percentile(a,90):.2f} deg; mean P(|e|<2 at worst epoch) {np.mean(pp[name]):.2f}")
