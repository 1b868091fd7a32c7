"""The 5-speed car's final drive and gear ratios for the least WLTC fuel, no slower from 0 to 100 km/h than
as built: scipy's SLSQP on invsim's exact gradient against a derivative-free search (COBYLA) on the same runs.

    python python/examples/optimise_gears.py

The model is models/si_engine_5speed.toml. The variables are the final drive i_f and the ratios of gears 2 to 5,
i_g[2] ... i_g[5] (first gear's ratio stays 3.58: i_f already sets first gear's overall ratio, and the two
together would leave the overall ratios, and so the fuel, unchanged along a curve), each within 25 % of the
car's value. The fuel is the headline's l/100 km of `Model.simulate(cycle="wltc3b", dt=1.0, ...)` with its
exact derivatives (`gradient=[...]`); the gear changes on the cycle stay those of the car's speed schedule.

The 0-100 km/h time is computed here, in closed form, at full load: the engine's torque T_e(w_e, p_i) from the
model file's own formulas with the manifold at ambient pressure (P_WOT) or at the throttle's largest air flow
(m_at max, whichever gives less), each gear from the launch (first gear's slipping clutch,
w_e = (w_g^4 + w_idle^4)^(1/4)) up to the shift engine speed N_SHIFT, then the next; so

    t_100 = sum over gears k of the integral from v_(k-1) to v_k of m_eff,k / (F_w,k(v) - F_res(v)) dv

with v_k = the speed at which gear k reaches N_SHIFT (capped at 100 km/h), each integral by 24-point
Gauss-Legendre. It is an analytic function of the ratios wherever no shift or throttle limit sits on 100 km/h,
and its derivatives are taken by the complex step, d t/d r = Im t(r + i h)/h with h = 1e-30 (Squire & Trapp,
SIAM Review 40, 1998): exact to rounding, without a difference's cancellation.
"""

import math
import sys
import time
import tomllib
from pathlib import Path

import numpy as np

import invsim

REPO = Path(__file__).resolve().parents[2]
MODEL = REPO / "models" / "si_engine_5speed.toml"
CYCLE = "wltc3b"
DT = 1.0
#: The variables: the final drive and gears 2 to 5 (first gear's ratio is fixed, see the module's docs).
NAMES = ["i_f", "i_g[2]", "i_g[3]", "i_g[4]", "i_g[5]"]
#: Manifold pressure at wide-open throttle (ambient), Pa, and the engine speed of a full-load upshift, rpm.
P_WOT = 1.0e5
N_SHIFT = 6000.0
V_100 = 100.0 / 3.6
NODES, WEIGHTS = np.polynomial.legendre.leggauss(24)


def car():
    """The model file's parameters and the gearbox's ratios (tomllib: the values as written)."""
    with open(MODEL, "rb") as f:
        t = tomllib.load(f)
    p = {k: v["value"] if isinstance(v, dict) else v for k, v in t["parameters"].items()}
    ratios = list(t["gearbox"]["parameters"]["i_g"])
    return p, ratios


def ratios_of(x, ratios):
    """(i_f, [i_g per gear]) for the variables x (NAMES' order) over the car's ratios."""
    g = list(ratios)
    g[1:5] = list(x[1:5])
    return x[0], g


def full_load_torque(p, w_e):
    """T_e at full load (the model file's definitions): p_i the smaller of P_WOT and the pressure at which the
    engine draws the throttle's largest air flow."""
    k_air = p["V_d"] / (p["R_a"] * p["T_i"])
    p_flow = (p["m_at_max"] * 4 * math.pi / (w_e * k_air) + p["y_i"]) / p["s_i"]
    p_i = np.where(np.real(p_flow) < P_WOT, p_flow, P_WOT)
    m_fc = (p["s_i"] * p_i - p["y_i"]) * k_air / (p["lambda"] * p["AFs"])
    imep = m_fc * p["Q_hv"] * p["eta_th"] / p["V_d"]
    s_p = p["S"] * w_e / math.pi
    k_b = math.sqrt(0.075 / p["B"])
    fric = (s_p**2 + p["S_eps"] ** 2) ** 0.9 - p["S_eps"] ** 1.8
    fmep = p["xi_aux"] * k_b * (0.464 + 0.0072 * fric) * p["Pi_bl"] * 1e5
    bmep = (imep - (p["p_e"] - p_i) - fmep) / (1 + 0.0215 * p["xi_aux"] * k_b)
    return bmep * p["V_d"] / (4 * math.pi)


def seconds_per_speed(p, ratio, first, v):
    """dt/dv = m_eff/(F_w - F_res) in the gear of overall ratio `ratio` at speed v (array)."""
    w_g = ratio * v / p["r_w"]
    w_e = (w_g**4 + p["w_idle"] ** 4) ** 0.25 if first else w_g
    f_w = p["eta_trm"] * ratio * full_load_torque(p, w_e) / p["r_w"]
    f_res = 0.5 * p["rho_a"] * p["C_d"] * p["A_f"] * v**2 + p["m"] * p["g_0"] * p["c_r"] * np.tanh(v / p["v_eps"])
    m_eff = p["m"] + p["eta_trm"] * ratio**2 * p["J_e"] / p["r_w"] ** 2
    return m_eff / (f_w - f_res)


def t_100(p, i_f, gears):
    """The 0-100 km/h time at full load, s (complex ratios give the complex step)."""
    w_shift = N_SHIFT * math.pi / 30
    total, v0 = 0.0, 0.0
    for k, i_g in enumerate(gears):
        ratio = i_g * i_f
        v1 = w_shift * p["r_w"] / ratio
        last = np.real(v1) >= V_100
        if last:
            v1 = V_100
        v = v0 + (v1 - v0) * (NODES + 1) / 2
        total = total + (v1 - v0) / 2 * np.sum(WEIGHTS * seconds_per_speed(p, ratio, k == 0, v))
        if last:
            return total
        v0 = v1
    raise ValueError("the car does not reach 100 km/h below the shift speed in top gear")


def t_100_and_gradient(p, ratios, x):
    """t_100 at x and its derivatives in x (complex step)."""
    i_f, gears = ratios_of(x, ratios)
    t = float(np.real(t_100(p, i_f, gears)))
    grad = np.empty(len(x))
    h = 1e-30
    for j in range(len(x)):
        xc = np.array(x, dtype=complex)
        xc[j] += 1j * h
        i_fc, gc = ratios_of(xc, ratios)
        grad[j] = np.imag(t_100(p, i_fc, gc)) / h
    return t, grad


class Fuel:
    """The WLTC l/100 km of the car with the ratios x and (with `gradient`) its exact derivatives, counting
    the runs."""

    def __init__(self, model):
        self.model = model
        self.runs = 0

    def params(self, x):
        return dict(zip(NAMES, (float(v) for v in x)))

    def value(self, x):
        self.runs += 1
        run = self.model.simulate(cycle=CYCLE, dt=DT, params=self.params(x), keep_series=False)
        return run.summary["headline"]["l_per_100km"]

    def value_and_gradient(self, x):
        self.runs += 1
        run = self.model.simulate(
            cycle=CYCLE, dt=DT, params=self.params(x), keep_series=False, gradient=NAMES
        )
        g = run.summary["gradient"]["headline.l_per_100km"]
        return run.summary["headline"]["l_per_100km"], np.array([g[n] for n in NAMES])


def problem():
    """The car's parameters and ratios, the start x0 (the car as built), the bounds and the time to beat."""
    p, ratios = car()
    p["m_at_max"] = 0.08
    x0 = np.array([p["i_f"]] + ratios[1:5])
    bounds = [(0.75 * v, 1.25 * v) for v in x0]
    t_max, _ = t_100_and_gradient(p, ratios, x0)
    return p, ratios, x0, bounds, t_max


def main():
    from scipy.optimize import minimize

    p, ratios, x0, bounds, t_max = problem()
    model = invsim.Model(str(MODEL))
    cons = lambda jac: {
        "type": "ineq",
        "fun": lambda x: t_max - t_100_and_gradient(p, ratios, x)[0],
        **({"jac": lambda x: -t_100_and_gradient(p, ratios, x)[1]} if jac else {}),
    }
    fuel = Fuel(model)
    f0 = fuel.value(x0)
    print(f"as built: {dict(zip(NAMES, x0))}: {f0:.5f} l/100 km, 0-100 km/h in {t_max:.3f} s")
    results = []
    for name, run in [
        (
            "SLSQP, invsim's gradient",
            lambda f: minimize(f.value_and_gradient, x0, jac=True, method="SLSQP", bounds=bounds,
                               constraints=[cons(True)], options={"ftol": 1e-9, "maxiter": 200}),
        ),
        (
            "COBYLA, no derivatives",
            lambda f: minimize(f.value, x0, method="COBYLA", bounds=bounds, constraints=[cons(False)],
                               options={"rhobeg": 0.05, "tol": 1e-7, "maxiter": 2000}),
        ),
    ]:
        f = Fuel(model)
        t0 = time.perf_counter()
        r = run(f)
        seconds = time.perf_counter() - t0
        t, _ = t_100_and_gradient(p, ratios, r.x)
        results.append((name, r, f.runs, seconds, t))
        print(f"{name}: {r.message}")
        print("  " + ", ".join(f"{n} = {v:.5f}" for n, v in zip(NAMES, r.x)))
        print(f"  {r.fun:.6f} l/100 km ({100 * (r.fun / f0 - 1):+.3f} %), 0-100 km/h in {t:.4f} s, "
              f"{f.runs} runs ({r.get('nit', '-')} iterations) in {seconds:.1f} s")
    (_, a, *_), (_, b, *_) = results
    print(f"largest difference of the ratios: {np.max(np.abs(a.x - b.x) / x0):.2e} relative, "
          f"of the fuel: {abs(a.fun - b.fun) / a.fun:.2e} relative")
    return 0


if __name__ == "__main__":
    sys.exit(main())
