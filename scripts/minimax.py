#!/usr/bin/env python3
"""Minimax coefficients of the float-only sin/cos and exp in core/src/fastmath.rs.

Remez exchange in 40-digit arithmetic (mpmath). Prints each polynomial's coefficients and its
weighted approximation error (the error before f32 rounding; core/tests/fastmath.rs measures
the total error of the f32 code):

- sin r = r + r^3 q(r^2), q of degree 2, relative error on |r| <= pi/4;
- cos r = 1 - r^2/2 + r^4 q(r^2), q of degree 2, absolute error on |r| <= pi/4;
- e^r = 1 + r q(r), q of degree 4, relative error on |r| <= ln(2)/2.

Usage: python3 scripts/minimax.py   (needs mpmath: pip install mpmath)
"""
import struct
import sys

try:
    import mpmath as mp
except ImportError:
    sys.exit("error: mpmath not found: pip install mpmath")

mp.mp.dps = 40


def remez(g, w, a, b, n, grid=4001, iters=30):
    """Polynomial p of degree n minimizing max |w(u) (g(u) - p(u))| on [a, b]."""
    m = n + 2
    # Start from Chebyshev extrema, nudged off the interval's midpoint (where weights vanish).
    xs = [(a + b) / 2 + (b - a) / 2 * mp.cos(mp.pi * (m - 1 - i + 0.1) / (m - 0.8)) for i in range(m)]
    points = [a + (b - a) * k / grid for k in range(grid + 1)]
    for _ in range(iters):
        mat = mp.matrix(m, m)
        rhs = mp.matrix(m, 1)
        for i, x in enumerate(xs):
            for j in range(n + 1):
                mat[i, j] = x**j
            mat[i, n + 1] = (-1) ** i / w(x)
            rhs[i] = g(x)
        sol = mp.lu_solve(mat, rhs)
        c = [sol[j] for j in range(n + 1)]

        def err(x):
            return w(x) * (g(x) - sum(c[j] * x**j for j in range(n + 1)))

        vals = [err(x) for x in points]
        # Local extrema of the error, merged into an alternating set of m points.
        ext = [0] + [k for k in range(1, grid) if (vals[k] - vals[k - 1]) * (vals[k + 1] - vals[k]) <= 0] + [grid]
        alt = []
        for k in ext:
            if alt and mp.sign(vals[k]) == mp.sign(vals[alt[-1]]):
                if abs(vals[k]) > abs(vals[alt[-1]]):
                    alt[-1] = k
            else:
                alt.append(k)
        while len(alt) > m:
            alt.pop(0 if abs(vals[alt[0]]) < abs(vals[alt[-1]]) else -1)
        xs = [points[k] for k in alt]
    return c, max(abs(v) for v in vals)


def f32_literal(x):
    """The shortest decimal that reads back as the f32 nearest to x."""
    target = struct.unpack("f", struct.pack("f", float(x)))[0]
    for digits in range(1, 10):
        text = f"{target:.{digits}g}"
        if struct.unpack("f", struct.pack("f", float(text)))[0] == target:
            return text
    return repr(target)


def show(name, coefs, names, err, kind):
    print(f"{name}: {kind} approximation error {mp.nstr(err, 3)}")
    for label, c in zip(names, coefs):
        print(f"    const {label}: f32 = {f32_literal(c)};")


tiny = mp.mpf("1e-30")
quarter_pi_sq = (mp.pi / 4) ** 2

# sin r = r (1 + u q(u)), u = r^2: relative error of sin = u |q_exact(u) - q(u)| (sin r / r ~ 1).
q_sin = lambda u: (mp.sin(mp.sqrt(u)) / mp.sqrt(u) - 1) / u if u > 0 else mp.mpf(-1) / 6
c, e = remez(q_sin, lambda u: u if u > 0 else tiny, mp.mpf(0), quarter_pi_sq, 2)
show("sin", c, ["S3", "S5", "S7"], e, "relative")

# cos r = 1 - u/2 + u^2 q(u): absolute error u^2 |q_exact(u) - q(u)|.
q_cos = lambda u: (mp.cos(mp.sqrt(u)) - 1 + u / 2) / u**2 if u > 0 else mp.mpf(1) / 24
c, e = remez(q_cos, lambda u: u * u if u > 0 else tiny, mp.mpf(0), quarter_pi_sq, 2)
show("cos", c, ["C4", "C6", "C8"], e, "absolute")

# e^r = 1 + r q(r): relative error |r| e^-r |q_exact(r) - q(r)|.
h = mp.log(2) / 2
q_exp = lambda r: (mp.exp(r) - 1) / r if r != 0 else mp.mpf(1)
c, e = remez(q_exp, lambda r: abs(r) / mp.exp(r) if r != 0 else tiny, -h, h, 4)
show("exp", c, ["E1", "E2", "E3", "E4", "E5"], e, "relative")
