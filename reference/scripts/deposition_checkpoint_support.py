# Independent reading of a deposition checkpoint: accepted moves per sweep over time, and the
# supported fraction (centre's horizontal projection strictly inside the hull of the contact
# points below, contacts within 1 % of d; or touching the substrate).
import json, struct, sys
import numpy as np
f = lambda b: struct.unpack('d', struct.pack('Q', b))[0]
c = json.load(open(sys.argv[1]))
r, L = 0.5e-6, 10e-6
for k, run in enumerate(c['runs']):
    if run is None: continue
    s = run['state']
    hist = np.array([[x[0], f(x[1]), f(x[2])] for x in s['history']])
    acc = hist[:, 2] * 1000
    n = len(hist)
    for a, b in [(0, 100), (100, 1000), (1000, 10000), (10000, 100000), (100000, n)]:
        if a < n: print(f"run {k}: sweeps {a}-{min(b,n)}: accepted moves per sweep {acc[a:b].mean():.3f}")
    last_acc = np.nonzero(acc)[0]
    print(f"run {k}: {n} sweeps, last sweep with an accepted move {last_acc[-1]+1}, accepted in the last 100000 sweeps: {acc[-100000:].sum():.0f}")
    P = np.array([[f(v) for v in p] for p in s['position']])
    sup = np.zeros(len(P), bool); ncont = np.zeros(len(P))
    for i, ci in enumerate(P):
        if ci[2] - r < 0.01 * 2 * r: sup[i] = True; continue
        dd = P - ci
        dd[:, :2] -= L * np.round(dd[:, :2] / L)
        dist = np.linalg.norm(dd, axis=1)
        m = (dist < 2 * r * 1.01) & (dd[:, 2] < 0) & (np.arange(len(P)) != i)
        ncont[i] = m.sum()
        if m.sum() < 3: continue
        ang = np.sort(np.arctan2(dd[m, 1], dd[m, 0]))
        gaps = np.diff(np.concatenate([ang, [ang[0] + 2 * np.pi]]))
        sup[i] = gaps.max() < np.pi
    z = P[:, 2]
    print(f"run {k}: supported {sup.mean():.4f}; unsupported: {(~sup).sum()}, their heights (d) {np.round(np.sort(z[~sup]) / 1e-6, 2)[:30]}, contacts below {ncont[~sup][:30]}")
