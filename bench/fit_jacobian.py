"""What a Jacobian of the MF Fy0 stage costs: finite differences vs exact forward-mode.

For the Fy0 stage (27 free coefficients, identify.fit.mf.stage_specs) on pure lateral points
(kappa = 0; useMode 211 as the stages use) at 1e4 and 1e5 points, on one core:

(a) one evaluation of Fy: numpy (lateral.fy0 on a precomputed OperatingState, as the stage
    model does) and the compiled kernel (identify.model.kernel.fused.evaluate_outputs(("Fy",)));
(b) a two-point finite-difference Jacobian: k + 1 = 28 evaluations of each;
(c) an exact Jacobian by forward-mode automatic differentiation: JAX ``jacfwd`` of the same
    Fy0 equations written in jax.numpy (compiled by XLA; compile time reported apart), if jax
    is installed (it is not a dependency: ``pip install jax``).

It also checks the JAX Fy against numpy (relative, to 1e-12) and the JAX Jacobian against
central differences (to 1e-5), so the numbers compare like with like.

    python bench/fit_jacobian.py [--repeats 5]
"""
from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")
os.environ.setdefault("XLA_FLAGS", "--xla_cpu_multi_thread_eigen=false "
                                   "intra_op_parallelism_threads=1")

import argparse  # noqa: E402
import math  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

from identify.fit.mf.stage_specs import STAGES  # noqa: E402
from identify.io.tir import read_tir  # noqa: E402
from identify.model import lateral  # noqa: E402
from identify.model.kernel.fused import evaluate_outputs  # noqa: E402
from identify.model.state import prepare  # noqa: E402

try:
    import jax
    import jax.numpy as jnp
    jax.config.update("jax_enable_x64", True)
except ImportError:  # pragma: no cover
    jax = None

ROOT = Path(__file__).resolve().parents[1]
TIR = ROOT / "tests" / "data" / "tir" / "testA_61.tir"
NAMES = STAGES["Fy0"].coefficients
MODE = 211
EPS = 1e-6


def _points(n: int, seed: int = 0):
    """Lateral sweeps: alpha +-15 deg at 3 loads, 3 pressures, 3 cambers (kappa = 0)."""
    rng = np.random.default_rng(seed)
    return {"fz": rng.choice([2000.0, 4000.0, 6000.0], n) * rng.uniform(0.98, 1.02, n),
            "kappa": np.zeros(n), "alpha": rng.uniform(-0.26, 0.26, n),
            "gamma": rng.choice([-0.05, 0.0, 0.05], n), "vx": np.full(n, 16.7),
            "p": rng.choice([1.8e5, 2.2e5, 2.6e5], n)}


def _fy0_jax(theta, fixed, s):
    """lateral.fy0 for useMode 211 (no limits, alpha* = alpha) in jax.numpy; theta in NAMES
    order, ``fixed`` the other parameters, ``s`` the state arrays."""
    P = dict(fixed)
    P.update({k: theta[j] for j, k in enumerate(NAMES)})
    dfz, dpi, fz, g, a, fz0p = s["dfz"], s["dpi"], s["fz"], s["gamma"], s["alpha"], s["fz0p"]

    def sgn1(x):
        return jnp.where(x < 0, -1.0, 1.0)

    kya = (P["PKY1"] * fz0p * (1 + P["PPY1"] * dpi) * (1 - P["PKY3"] * jnp.abs(g))
           * jnp.sin(P["PKY4"] * jnp.arctan((fz / fz0p) / ((P["PKY2"] + P["PKY5"] * g ** 2)
                                                          * (1 + P["PPY2"] * dpi)))) * P["LKY"])
    svyg = fz * (P["PVY3"] + P["PVY4"] * dfz) * g * P["LKYC"] * P["LMUY"]
    kyg0 = fz * (P["PKY6"] + P["PKY7"] * dfz) * (1 + P["PPY5"] * dpi) * P["LKYC"]
    shy = (P["PHY1"] + P["PHY2"] * dfz) * P["LHY"] + (kyg0 * g - svyg) / (kya + EPS * sgn1(kya))
    svy = fz * (P["PVY1"] + P["PVY2"] * dfz) * P["LVY"] * P["LMUY"] + svyg
    alpha_y = a + shy
    cy = P["PCY1"] * P["LCY"]
    muy = ((P["PDY1"] + P["PDY2"] * dfz) * (1 + P["PPY3"] * dpi + P["PPY4"] * dpi ** 2)
           * (1 - P["PDY3"] * g ** 2) * P["LMUY"])
    dy = muy * fz
    ey = ((P["PEY1"] + P["PEY2"] * dfz)
          * (1 + P["PEY5"] * g ** 2 - (P["PEY3"] + P["PEY4"] * g) * sgn1(alpha_y)) * P["LEY"])
    by = kya / (cy * dy + EPS * sgn1(dy))
    bx = by * alpha_y
    return dy * jnp.sin(cy * jnp.arctan(bx - ey * (bx - jnp.arctan(bx)))) + svy


def _best(fn, repeats: int) -> float:
    best = math.inf
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return best


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args()
    P = read_tir(TIR).params()
    theta0 = np.array([P[k] for k in NAMES])
    k = len(NAMES)
    print(f"Fy0 stage: {k} free coefficients, useMode {MODE}, one core; best of "
          f"{args.repeats}; times in ms")
    print(f"{'points':>7} {'np eval':>8} {'kern eval':>9} {'np FD':>8} {'kern FD':>8} "
          f"{'jax eval':>8} {'jax jac':>8} {'jax compile s':>13}")
    for n in (10_000, 100_000):
        pts = _points(n)
        s = prepare(P, **pts, mode=MODE)

        def with_theta(theta):
            Q = dict(P)
            Q.update(zip(NAMES, theta))
            return Q

        def np_eval(theta=theta0, s=s):
            return lateral.fy0(with_theta(theta), s).fy0

        def kern_eval(theta=theta0, pts=pts):
            return evaluate_outputs(with_theta(theta), ("Fy",), **pts, mode=MODE)["Fy"]

        def fd(fn, n=n):
            f0 = fn()
            jac = np.empty((n, k))
            for j in range(k):
                t = theta0.copy()
                h = 1e-7 * max(1.0, abs(t[j]))
                t[j] += h
                jac[:, j] = (fn(t) - f0) / h
            return jac

        kern_eval()  # compile or load
        assert np.max(np.abs(kern_eval() - np_eval()) / np.maximum(1, np.abs(np_eval()))) < 1e-10
        t_np = _best(np_eval, args.repeats)
        t_k = _best(kern_eval, args.repeats)
        t_np_fd = _best(lambda: fd(np_eval), max(1, args.repeats // 2))
        t_k_fd = _best(lambda: fd(kern_eval), max(1, args.repeats // 2))
        line = (f"{n:>7} {t_np * 1e3:>8.2f} {t_k * 1e3:>9.2f} {t_np_fd * 1e3:>8.1f} "
                f"{t_k_fd * 1e3:>8.1f}")
        if jax is not None:
            fixed = {key: float(v) for key, v in P.items() if isinstance(v, (int, float))}
            sj = {"dfz": jnp.asarray(s.dfz), "dpi": jnp.asarray(s.dpi), "fz": jnp.asarray(s.fz),
                  "gamma": jnp.asarray(s.gamma_star), "alpha": jnp.asarray(s.alpha_star),
                  "fz0p": s.fz0p}
            f = jax.jit(lambda th, fixed=fixed, sj=sj: _fy0_jax(th, fixed, sj))
            jac = jax.jit(jax.jacfwd(lambda th, fixed=fixed, sj=sj: _fy0_jax(th, fixed, sj)))
            th = jnp.asarray(theta0)
            t0 = time.perf_counter()
            f(th).block_until_ready()
            jac(th).block_until_ready()
            t_compile = time.perf_counter() - t0
            fy_ref = np_eval()
            fy_jax = np.asarray(f(th))
            assert np.max(np.abs(fy_jax - fy_ref) / np.maximum(1, np.abs(fy_ref))) < 1e-12
            j_jax = np.asarray(jac(th))
            j_c = np.empty_like(j_jax)  # central differences as a check of the exact Jacobian
            for j in range(k):
                h = 1e-5 * max(1.0, abs(theta0[j]))
                tp, tm = theta0.copy(), theta0.copy()
                tp[j] += h
                tm[j] -= h
                j_c[:, j] = (np_eval(tp) - np_eval(tm)) / (2 * h)
            scale = np.max(np.abs(j_c), axis=0) + 1e-30
            assert np.max(np.abs(j_jax - j_c) / scale) < 1e-5, np.max(np.abs(j_jax - j_c) / scale)
            t_je = _best(lambda f=f, th=th: f(th).block_until_ready(), args.repeats)
            t_jj = _best(lambda jac=jac, th=th: jac(th).block_until_ready(), args.repeats)
            line += f" {t_je * 1e3:>8.2f} {t_jj * 1e3:>8.2f} {t_compile:>13.1f}"
        else:
            line += "   (jax not installed: pip install jax)"
        print(line)


if __name__ == "__main__":
    main()
