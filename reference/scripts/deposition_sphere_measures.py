# Independent measures of a sphere deposit: mean top height h from a height map (5 nodes per
# radius), core packing fraction over [2 d, h - 2 d] by exact sphere-slab volumes, first-layer
# coverage (nodes under spheres touching the substrate within 1 % of r).
import json, struct, sys
import numpy as np
r, L = 0.5e-6, 10e-6
def load(path, run=None):
    if path.endswith('.xyz'):
        lines = open(path).read().split('\n')[2:]
        return np.array([[float(x) for x in l.split()[1:4]] for l in lines if l.strip()])
    f = lambda b: struct.unpack('d', struct.pack('Q', b))[0]
    c = json.load(open(path))
    return np.array([[f(v) for v in p] for p in c['runs'][run]['state']['position']])
def measure(P):
    n = int(np.ceil(L / r * 5))
    g = (np.arange(n) + 0.5) * L / n
    X, Y = np.meshgrid(g, g, indexing='ij')
    top = np.zeros_like(X); cover = np.zeros(X.shape, bool)
    for p in P:
        dx = X - p[0]; dx -= L * np.round(dx / L)
        dy = Y - p[1]; dy -= L * np.round(dy / L)
        rho2 = dx * dx + dy * dy
        m = rho2 < r * r
        top[m] = np.maximum(top[m], p[2] + np.sqrt(r * r - rho2[m]))
        if p[2] - r < 0.01 * r: cover |= m
    h = top.mean()
    lo, hi = 4 * r, h - 4 * r
    def cap(z):  # volume of a sphere of radius r below height z measured from its centre
        z = np.clip(z, -r, r)
        return np.pi * (r * r * (z + r) - (z ** 3 + r ** 3) / 3)
    v = (cap(hi - P[:, 2]) - cap(lo - P[:, 2])).sum()
    return h, v / (L * L * (hi - lo)), cover.mean()
for spec in sys.argv[1:]:
    path, _, run = spec.partition(':')
    P = load(path, int(run) if run else None)
    h, phi, cov = measure(P)
    print(f"{spec}: h = {h:.4e} m, core packing {phi:.4f}, first-layer coverage {cov:.4f}")
