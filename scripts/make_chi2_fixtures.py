"""Prints the reference values of the large-ν χ² tails and quantiles in `src/stats.rs`'s tests,
in 40-digit arithmetic (mpmath, which scipy depends on). scipy's own chi2.cdf is not a reference
there: at ν = 4e6, 6σ below the mean, it is off by 6e-5 relative.

python3 scripts/make_chi2_fixtures.py
"""
import mpmath as mp

mp.mp.dps = 40


def cdf(x, nu):
    try:
        return mp.gammainc(mp.mpf(nu) / 2, 0, mp.mpf(x) / 2, regularized=True)
    except mp.libmp.libhyper.NoConvergence:  # the series is too long there: 1 − Q
        return 1 - sf(x, nu)


def sf(x, nu):
    return mp.gammainc(mp.mpf(nu) / 2, mp.mpf(x) / 2, mp.inf, regularized=True)


print("// (ν, z, P, Q) at x = ν + z·√(2ν) (x rounded to f64 first)")
for nu in (1e5, 4e6):
    for z in (-6.0, -1.0, -0.001, 0.0, 0.5, 3.0, 9.0):
        x = float(nu + z * (2.0 * nu) ** 0.5)
        print(f"({nu:e}, {z}, {float(cdf(x, nu))!r}, {float(sf(x, nu))!r}),")
print("// (ν, p, x) with P(X ≤ x) = p")
for nu in (1e5, 4e6):
    for p in ("1e-9", "0.025", "0.5", "0.975"):
        p = mp.mpf(p)
        guess = nu * (1 - 2 / (9 * nu) + mp.sqrt(2) * mp.erfinv(2 * p - 1) * mp.sqrt(2 / (9 * nu))) ** 3
        x = mp.findroot(lambda x: cdf(x, nu) - p, guess)
        print(f"({nu:e}, {float(p)!r}, {float(x)!r}),")
