#!/usr/bin/env python3
"""Oracle values for tests/sh_oracle.rs, computed outside shvis at high precision.

Rerun (from the repository root):

    python3 -m pip install mpmath sympy scipy numpy
    python3 tests/data/make_sh_reference.py

It rewrites, next to this script:

  sh_basis_order13.csv   real SH y_l^m for l <= 12 (169 values) at 20 random unit
                         directions (fixed seed), the exact poles (0, 0, +-1) and
                         directions 1e-9 from them (on the x axis and off-axis).
  gaunt_3_3_6.csv        nonzero real Gaunt coefficients T(i, j, k) = int y_i y_j y_k dw
  gaunt_4_4_4.csv        for the order triples (a, b, c) in the name: i < a^2, j < b^2,
  gaunt_6_3_8.csv        k < c^2, flat index i = l(l+1)+m. Entries not listed are zero.

Conventions (DESIGN section 1): real SH with the Condon-Shortley phase,
y_1^-1 = -sqrt(3/4pi) y, y_1^0 = sqrt(3/4pi) z, y_1^1 = -sqrt(3/4pi) x, i.e.

  y_l^m  = sqrt(2) Re Y_l^m   (m > 0)
  y_l^-m = sqrt(2) Im Y_l^m   (m > 0)
  y_l^0  = Y_l^0

with Y_l^m the complex SH of mpmath.spherharm (Condon-Shortley phase included). The
script asserts the band-1 closed forms above before writing anything.

Independent sources, none of them shvis code:
  * basis: mpmath.spherharm at 40 digits, theta = acos(z), phi = atan2(y, x) computed
    in mpmath from the exact binary value of each f64 direction component;
  * Gaunt: sympy.physics.wigner.gaunt (exact, complex SH, Condon-Shortley phase)
    converted to the real basis with the unitary map above, evaluated to 40 digits;
    a sample of entries (and of entries absent from the files) is re-checked by an
    exact 40-digit product quadrature of the real basis (Gauss-Legendre in z with
    nodes found in mpmath, uniform in phi).

Values are printed with 20 significant digits (f64 needs 17 to round-trip); direction
components are the f64 values themselves, printed with repr() (round-trip exact).
"""

import math
import os
import random
import sys

import mpmath as mp
from sympy import N as sym_n
from sympy.physics.wigner import gaunt as complex_gaunt

mp.mp.dps = 40
HERE = os.path.dirname(os.path.abspath(__file__))
DIGITS = 20
SEED = 20240613
RANDOM_DIRECTIONS = 20
BASIS_ORDER = 13
GAUNT_ORDERS = [(3, 3, 6), (4, 4, 4), (6, 3, 8)]


def fmt(v):
    """20 significant digits, exponent form; exact zeros as 0.0."""
    return mp.nstr(mp.mpf(v), DIGITS, min_fixed=0, max_fixed=0)


def flat(l, m):
    return l * (l + 1) + m


def lm_of(i):
    l = int(mp.floor(mp.sqrt(i)))
    while (l + 1) * (l + 1) <= i:
        l += 1
    while l * l > i:
        l -= 1
    return l, i - l * (l + 1)


def real_basis(order, x, y, z):
    """All y_l^m for l < order at the direction (x, y, z) (normalised here in mpmath)."""
    x, y, z = mp.mpf(x), mp.mpf(y), mp.mpf(z)
    r = mp.sqrt(x * x + y * y + z * z)
    x, y, z = x / r, y / r, z / r
    theta = mp.acos(z)
    phi = mp.atan2(y, x)
    out = [mp.mpf(0)] * (order * order)
    for l in range(order):
        out[flat(l, 0)] = mp.re(mp.spherharm(l, 0, theta, phi))
        for m in range(1, l + 1):
            c = mp.spherharm(l, m, theta, phi)
            out[flat(l, m)] = mp.sqrt(2) * mp.re(c)
            out[flat(l, -m)] = mp.sqrt(2) * mp.im(c)
    return out


def check_band_1():
    k = mp.sqrt(3 / (4 * mp.pi))
    rng = random.Random(1)
    for _ in range(5):
        d = [rng.gauss(0.0, 1.0) for _ in range(3)]
        n = mp.sqrt(sum(mp.mpf(c) ** 2 for c in d))
        x, y, z = (mp.mpf(c) / n for c in d)
        b = real_basis(2, x, y, z)
        want = [1 / (2 * mp.sqrt(mp.pi)), -k * y, k * z, -k * x]
        for got, w in zip(b, want):
            assert abs(got - w) < mp.mpf(10) ** -35, (got, w)


def directions():
    rng = random.Random(SEED)
    dirs = []
    for _ in range(RANDOM_DIRECTIONS):
        while True:
            v = [rng.gauss(0.0, 1.0) for _ in range(3)]
            n = sum(c * c for c in v) ** 0.5
            if n > 1e-3:
                break
        dirs.append(tuple(c / n for c in v))
    eps = 1e-9
    near = (1.0 - eps * eps) ** 0.5  # rounds to 1.0 in f64; kept as the formula
    az = 2.5  # off-axis azimuth (radians)
    for s in (1.0, -1.0):
        dirs.append((0.0, 0.0, s))
        dirs.append((eps, 0.0, s * near))
        dirs.append((eps * math.cos(az), eps * math.sin(az), s * near))
    return dirs


def write_basis():
    path = os.path.join(HERE, "sh_basis_order13.csv")
    n = BASIS_ORDER * BASIS_ORDER
    with open(path, "w") as f:
        f.write("# real SH y_i, i = l(l+1)+m, l < 13, DESIGN section 1 convention; "
                "written by tests/data/make_sh_reference.py (mpmath.spherharm, 40 digits)\n")
        f.write("x,y,z," + ",".join(f"y{i}" for i in range(n)) + "\n")
        for x, y, z in directions():
            vals = real_basis(BASIS_ORDER, x, y, z)
            f.write(",".join([repr(x), repr(y), repr(z)] + [fmt(v) for v in vals]) + "\n")
    print(f"wrote {path}")


# Real <- complex: y_l^m = sum_mu U[m][mu] Y_l^mu.
def real_from_complex(m):
    s = mp.sqrt(2)
    if m == 0:
        return [(0, mp.mpc(1))]
    a = abs(m)
    sign = -1 if a % 2 else 1
    if m > 0:
        return [(a, mp.mpc(1) / s), (-a, mp.mpc(sign) / s)]
    return [(a, mp.mpc(1) / (mp.mpc(0, 1) * s)), (-a, mp.mpc(-sign) / (mp.mpc(0, 1) * s))]


_gaunt_cache = {}


def cgaunt(l1, l2, l3, m1, m2, m3):
    key = (l1, l2, l3, m1, m2, m3)
    if key not in _gaunt_cache:
        _gaunt_cache[key] = mp.mpf(str(sym_n(complex_gaunt(l1, l2, l3, m1, m2, m3), 45)))
    return _gaunt_cache[key]


def real_gaunt(l1, m1, l2, m2, l3, m3):
    total = mp.mpc(0)
    for mu1, c1 in real_from_complex(m1):
        for mu2, c2 in real_from_complex(m2):
            for mu3, c3 in real_from_complex(m3):
                if mu1 + mu2 + mu3 != 0:
                    continue
                total += c1 * c2 * c3 * cgaunt(l1, l2, l3, mu1, mu2, mu3)
    assert abs(mp.im(total)) < mp.mpf(10) ** -30, total
    return mp.re(total)


def allowed(l1, m1, l2, m2, l3, m3):
    """Selection rules; only a prefilter, every kept value is computed exactly."""
    if l3 < abs(l1 - l2) or l3 > l1 + l2 or (l1 + l2 + l3) % 2:
        return False
    a1, a2, a3 = abs(m1), abs(m2), abs(m3)
    return a3 == a1 + a2 or a3 == abs(a1 - a2)


def gauss_legendre_mp(n):
    """n-point Gauss-Legendre nodes and weights on [-1, 1], Newton on mpmath's P_n."""
    nodes, weights = [], []
    for k in range(1, n + 1):
        x = mp.cos(mp.pi * (k - mp.mpf(1) / 4) / (n + mp.mpf(1) / 2))
        for _ in range(100):
            p, dp = mp.legendre(n, x), mp.diff(lambda t: mp.legendre(n, t), x)
            dx = p / dp
            x -= dx
            if abs(dx) < mp.mpf(10) ** (-mp.mp.dps + 5):
                break
        dp = mp.diff(lambda t: mp.legendre(n, t), x)
        nodes.append(x)
        weights.append(2 / ((1 - x * x) * dp * dp))
    return nodes, weights


def real_y(l, m, theta, phi):
    if m == 0:
        return mp.re(mp.spherharm(l, 0, theta, phi))
    c = mp.spherharm(l, abs(m), theta, phi)
    return mp.sqrt(2) * (mp.re(c) if m > 0 else mp.im(c))


def quadrature_gaunt(i, j, k):
    """Exact product rule (degree l1+l2+l3 polynomial): Gauss-Legendre in z, uniform phi."""
    lms = [lm_of(i), lm_of(j), lm_of(k)]
    degree = sum(l for l, _ in lms)
    nodes, weights = gauss_legendre_mp(degree // 2 + 1)
    n_phi = degree + 1
    total = mp.mpf(0)
    for z, w in zip(nodes, weights):
        theta = mp.acos(z)
        for b in range(n_phi):
            phi = 2 * mp.pi * (b + mp.mpf(1) / 2) / n_phi
            v = w * 2 * mp.pi / n_phi
            for l, m in lms:
                v *= real_y(l, m, theta, phi)
            total += v
    return total


def write_gaunt(a, b, c):
    rows = []
    for i in range(a * a):
        l1, m1 = lm_of(i)
        for j in range(b * b):
            l2, m2 = lm_of(j)
            for k in range(c * c):
                l3, m3 = lm_of(k)
                if not allowed(l1, m1, l2, m2, l3, m3):
                    continue
                v = real_gaunt(l1, m1, l2, m2, l3, m3)
                if v != 0:
                    rows.append((i, j, k, v))
    path = os.path.join(HERE, f"gaunt_{a}_{b}_{c}.csv")
    with open(path, "w") as f:
        f.write(f"# nonzero real Gaunt coefficients int y_i y_j y_k dw, i < {a * a}, "
                f"j < {b * b}, k < {c * c}; written by tests/data/make_sh_reference.py "
                "(sympy.physics.wigner.gaunt converted to the real basis)\n")
        f.write("i,j,k,value\n")
        for i, j, k, v in rows:
            f.write(f"{i},{j},{k},{fmt(v)}\n")
    print(f"wrote {path}: {len(rows)} nonzero entries")
    return rows


def main():
    check_band_1()
    write_basis()
    rng = random.Random(SEED + 1)
    for a, b, c in GAUNT_ORDERS:
        rows = write_gaunt(a, b, c)
        # Cross-check the complex -> real conversion by direct quadrature of the real basis.
        for i, j, k, v in rng.sample(rows, 4):
            q = quadrature_gaunt(i, j, k)
            assert abs(q - v) < mp.mpf(10) ** -30, (i, j, k, v, q)
        # And a few entries the prefilter or the exact sum says are zero.
        for _ in range(4):
            i, j, k = rng.randrange(a * a), rng.randrange(b * b), rng.randrange(c * c)
            if any(r[:3] == (i, j, k) for r in rows):
                continue
            q = quadrature_gaunt(i, j, k)
            assert abs(q) < mp.mpf(10) ** -30, (i, j, k, q)
    print("cross-checks passed")
    return 0


if __name__ == "__main__":
    sys.exit(main())
