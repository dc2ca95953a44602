"""Long-run stability of the GC coupling as specified (THEORY.md §3), without any dissipation.

    .venv/bin/python benchmarks/gc_stability.py

Two independent measurements:

1. The package itself: the split bar clamped at its right end (`demos/split_bar_undamped.toml`), no
   wall, a cos² pulse, no damping, CD-Lagrange | Newmark (average acceleration) with GC at
   ratio m, run for 200 time units (≈ 44 000 micro steps). A stable coupling keeps
   kinetic + internal energy bounded by its initial value (GC should only dissipate); we
   report max(E)/E0 and the final interface-dissipated energy.
2. The amplification matrix of one macro step of the same algorithm, written out in 40 lines
   of numpy for two 6-node chains (explicit | implicit, implicit end clamped): its spectral
   radius ρ. ρ > 1 means some mode grows by ρ per macro step however small Δt is.

Measured: the j/m-weighted interface operator H_j = ½Δt W_E + (j/m) γ ΔT W_I (THEORY.md §3,
``coupling.method = "gc"``), the constant one (j/m → 1), the causal energy-conserving form
tried and dropped (docs/theory-notes.md §6) and the package's ``coupling.method = "ec"``
(§7) and ``"gc-mean"`` (§9), with the fraction of a pulse's energy each one reflects at the
interface of two 200-node chains (Gaussian of width 30 elements, and 90 for "ec").
"""

from __future__ import annotations

import subprocess
import sys
import tempfile
from collections.abc import Callable
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent


def _chain(n: int) -> tuple[np.ndarray, np.ndarray]:
    K = np.zeros((n, n))
    M = np.ones(n)
    for e in range(n - 1):
        K[e : e + 2, e : e + 2] += np.array([[1.0, -1.0], [-1.0, 1.0]])
    M[0] *= 0.5
    M[-1] *= 0.5
    return K, M


def _macro_step(
    m: int, variant: str, n: int, clamp: bool
) -> tuple[Callable[[np.ndarray], np.ndarray], float, np.ndarray, np.ndarray]:
    """One macro step of two n-node chains (CD explicit | Newmark average acceleration, the
    implicit far end clamped or free) coupled by ``variant``: "jm" (H_j weighted by j/m),
    "const" (j/m → 1), "causal" (the causal energy-conserving form tried and dropped,
    docs/theory-notes.md §6) or "ec" (the package's ``coupling.method = "ec"``: G constant
    over the macro step, continuity of the interface displacement increment, §7).
    State: (u_E, v_E,j−½, u_I, v_I, a_I, Λ_I). Returns the step, Δt and the explicit chain's
    K and lumped M."""
    KB, MB = _chain(n)
    KA, MA_l = _chain(n)
    dt = 0.9 * 2.0 / np.sqrt(np.max(np.linalg.eigvalsh(KB / np.sqrt(np.outer(MB, MB)))))
    dT, beta, gamma = m * dt, 0.25, 0.5
    Mt = np.diag(MA_l) + beta * dT**2 * KA
    if clamp:
        Mt[-1, :] = 0.0
        Mt[:, -1] = 0.0
        Mt[-1, -1] = 1.0
    Mti = np.linalg.inv(Mt)
    LA = np.zeros(n)
    LA[0] = -1.0
    LB = np.zeros(n)
    LB[-1] = 1.0
    WA, WB = LA @ Mti @ LA, LB @ (LB / MB)

    def explicit_pass(uB: np.ndarray, vh: np.ndarray, G: float) -> tuple[np.ndarray, ...]:
        """m CD steps under the constant interface force G; (U_m, V_m+½, L_B D_B)."""
        d0 = LB @ (uB + 0.5 * dt * vh)
        for _ in range(m):
            uB = uB + dt * vh
            vh = vh + dt * (LB * G - KB @ uB) / MB
        return uB, vh, LB @ (uB + 0.5 * dt * vh) - d0

    def step_ec(x: np.ndarray) -> np.ndarray:
        """The package's "ec": G constant over the macro step, L_B D_B + L_A ΔU_A = 0."""
        uB, vh, uA, vA, aA, _ = np.split(x, [n, 2 * n, 3 * n, 4 * n, 5 * n])
        r = -KA @ uA
        if clamp:
            r[-1] = 0.0
        du_free = Mti @ (dT * MA_l * vA + 0.5 * dT**2 * r)
        link = 0.5 * dT**2 * (Mti @ LA)  # ΔU_A per unit G

        def residual(G: float) -> float:
            return float(explicit_pass(uB, vh, G)[2] + LA @ (du_free + G * link))

        r0 = residual(0.0)
        G = -r0 / (residual(1.0) - r0)  # affine in G
        uB, vh, _ = explicit_pass(uB, vh, G)
        du = du_free + G * link
        return np.concatenate([uB, vh, uA + du, 2 * du / dT - vA, aA, [G]])

    def step_mean(x: np.ndarray) -> np.ndarray:
        """The package's "gc-mean": target of every micro step the implicit mean velocity
        a = L_A ΔU_free / ΔT plus ½ m W_A Λ̂_j; the implicit side paid the total impulse."""
        uB, vh, uA, vA, aA, _ = np.split(x, [n, 2 * n, 3 * n, 4 * n, 5 * n])
        r = -KA @ uA
        if clamp:
            r[-1] = 0.0
        du_free = Mti @ (dT * MA_l * vA + 0.5 * dT**2 * r)
        a = LA @ du_free / dT
        y0, yf = LA @ vA, LA @ (2 * du_free / dT - vA)
        S = 0.0
        for j in range(1, m + 1):
            uB = uB + dt * vh
            vfree = vh - dt * (KB @ uB) / MB
            if variant == "interp":  # the free part interpolated instead (not dissipative)
                a = (1 - j / m) * y0 + (j / m) * yf
            lam = -(LB @ (0.5 * (vh + vfree)) + a) / (0.5 * WB + 0.5 * m * WA)
            S += lam
            vh = vfree + LB * lam / MB
        du = du_free + 0.5 * dT * (Mti @ (LA * S))
        return np.concatenate([uB, vh, uA + du, 2 * du / dT - vA, aA, [S / dT]])

    def implicit_free(uA: np.ndarray, vA: np.ndarray, aA: np.ndarray) -> tuple[np.ndarray, ...]:
        """Newmark predictor–solve of the implicit chain without link force: (U, V, A)."""
        ut = uA + dT * vA + dT**2 * (0.5 - beta) * aA
        vt = vA + dT * (1 - gamma) * aA
        r = -KA @ ut
        if clamp:
            r[-1] = 0.0
        af = Mti @ r
        return ut + beta * dT**2 * af, vt + gamma * dT * af, af

    def ph_pass(uB: np.ndarray, vh: np.ndarray, l0: float, l1: float) -> tuple[np.ndarray, ...]:
        """m CD steps under the impulses Δt((1 − j/m) l0 + (j/m) l1); (U_m, V_m+½, L_B V_m)."""
        w = 0.0
        for j in range(1, m + 1):
            uB = uB + dt * vh
            vfree = vh - dt * (KB @ uB) / MB
            lam = dt * ((1 - j / m) * l0 + (j / m) * l1)
            v_new = vfree + LB * lam / MB
            w = LB @ (0.5 * (vh + v_new))
            vh = v_new
        return uB, vh, w

    def step_ph(x: np.ndarray) -> np.ndarray:
        """Prakash–Hjelmstad as THEORY.md §3 and the package's "ph": Λ linear over the macro
        step on the explicit side, velocity continuity at the macro step only, the implicit
        side (acceleration form) corrected with the end multiplier."""
        uB, vh, uA, vA, aA, lam_a = np.split(x, [n, 2 * n, 3 * n, 4 * n, 5 * n])
        uf, vf, af = implicit_free(uA, vA, aA)
        w_free = ph_pass(uB, vh, lam_a[0], 0.0)[2]
        z = ph_pass(np.zeros(n), np.zeros(n), 0.0, 1.0)[2]  # linear: response to a unit ramp
        lam_b = -(w_free + LA @ vf) / (z + gamma * dT * WA)
        uB, vh, _ = ph_pass(uB, vh, lam_a[0], lam_b)
        da = Mti @ (LA * lam_b)
        return np.concatenate(
            [uB, vh, uf + beta * dT**2 * da, vf + gamma * dT * da, af + da, [lam_b]]
        )

    def step(x: np.ndarray) -> np.ndarray:
        if variant == "ec":
            return step_ec(x)
        if variant == "ph":
            return step_ph(x)
        if variant in ("mean", "interp"):
            return step_mean(x)
        uB, vh, uA, vA, aA, lam_a = np.split(x, [n, 2 * n, 3 * n, 4 * n, 5 * n])
        uf, vf, af = implicit_free(uA, vA, aA)
        w0, wf = LA @ vA, LA @ vf
        c = 0.5 * (w0 + wf - (1 - gamma) * dT * WA * lam_a[0])
        lam, S = 0.0, 0.0
        for j in range(1, m + 1):
            uB = uB + dt * vh
            vfree = vh - dt * (KB @ uB) / MB
            s = j / m
            if variant == "causal":
                lam = -(LB @ (0.5 * (vh + vfree)) + c + WA * S) / (0.5 * dt * (WB + WA))
            else:
                H = 0.5 * dt * WB + (s if variant == "jm" else 1.0) * gamma * dT * WA
                lam = -(LB @ (0.5 * (vh + vfree)) + (1 - s) * w0 + s * wf) / H
            S += dt * lam
            vh = vfree + dt * LB * lam / MB
        lam_n = (S / dT - (1 - gamma) * lam_a[0]) / gamma if variant == "causal" else lam
        da = Mti @ (LA * lam_n)
        return np.concatenate(
            [uB, vh, uf + beta * dT**2 * da, vf + gamma * dT * da, af + da, [lam_n]]
        )

    return step, dt, KB, MB


def spectral_radius(m: int, variant: str, n: int = 6) -> float:
    """ρ of one macro step of two 6-node chains, implicit far end clamped."""
    step, _, _, _ = _macro_step(m, variant, n, clamp=True)
    A = np.column_stack([step(e) for e in np.eye(5 * n + 1)])
    return float(np.max(np.abs(np.linalg.eigvals(A))))


def hughes_growth(m: int, n: int = 6, steps: int = 2000) -> tuple[float, float]:
    """Cross-check written independently of ``_macro_step``: THEORY.md §3 in Newmark
    (acceleration) form for both sides — explicit CD as Newmark β = 0, γ = ½ with state
    (U, V, A), implicit average acceleration — on two n-node chains, the implicit far end
    clamped by a spring. Returns ρ of one macro step and the growth over ``steps`` macro
    steps, along the dominant mode, of the energy of the GC proof (Hughes' energy method):
    ½VᵀMV + ½UᵀKU − Δt²/8 AᵀMA (CD) plus ½VᵀMV + ½UᵀKU (average acceleration), positive
    definite under the CFL condition. Growth > 1 means that some macro steps create
    interface energy in that measure, whatever the initial state."""
    KE, ME = _chain(n)
    KI, MI = _chain(n)
    KI[-1, -1] += 1.0  # far end held by a spring: no rigid mode
    MEi = np.diag(1.0 / ME)
    dt = 0.5 * 2.0 / np.sqrt(np.max(np.linalg.eigvalsh(KE / np.sqrt(np.outer(ME, ME)))))
    dT = m * dt
    Mt = np.diag(MI) + 0.25 * dT**2 * KI
    LE, LI = np.eye(n)[-1], -np.eye(n)[0]
    WE, WI = LE @ MEi @ LE, LI @ np.linalg.solve(Mt, LI)

    def step(x: np.ndarray) -> np.ndarray:
        uE, vE, aE, uI, vI, aI = np.split(x, 6)
        up, vp = uI + dT * vI + 0.25 * dT**2 * aI, vI + 0.5 * dT * aI
        af = np.linalg.solve(Mt, -KI @ up)
        vf = vp + 0.5 * dT * af
        lam = 0.0
        for j in range(1, m + 1):
            uE = uE + dt * vE + 0.5 * dt**2 * aE
            a_free = MEi @ (-KE @ uE)
            v_free = vE + 0.5 * dt * (aE + a_free)
            s = j / m
            lam = -(LE @ v_free + LI @ ((1 - s) * vI + s * vf)) / (
                0.5 * dt * WE + s * 0.5 * dT * WI
            )
            aE = a_free + MEi @ LE * lam
            vE = v_free + 0.5 * dt * MEi @ LE * lam
        al = np.linalg.solve(Mt, LI * lam)
        return np.concatenate(
            [uE, vE, aE, up + 0.25 * dT**2 * (af + al), vf + 0.5 * dT * al, af + al]
        )

    A = np.column_stack([step(e) for e in np.eye(6 * n)])
    w, vecs = np.linalg.eig(A)
    k = int(np.argmax(np.abs(w)))
    x = np.real(vecs[:, k])

    def energy(x: np.ndarray) -> float:
        uE, vE, aE, uI, vI, _ = np.split(x, 6)
        e_e = 0.5 * vE @ (ME * vE) + 0.5 * uE @ KE @ uE - dt**2 / 8 * aE @ (ME * aE)
        return float(e_e + 0.5 * vI @ (MI * vI) + 0.5 * uI @ KI @ uI)

    e0 = energy(x)
    for _ in range(steps):
        x = A @ x
    return float(np.abs(w[k])), energy(x) / e0


def pulse_balance(m: int, variant: str, width: float = 30.0) -> tuple[float, float]:
    """(explicit, implicit) physical energy / E0 after a right-travelling Gaussian pulse has
    crossed from the explicit chain into the implicit one (two chains of n = max(200,
    7 width) nodes, free far end: the pulse fits in the explicit chain; the implicit side's
    energy ½VᵀMV + ½UᵀKU)."""
    n = max(200, int(7 * width))
    step, dt, KB, MB = _macro_step(m, variant, n, clamp=False)
    KA, MA = _chain(n)
    x = np.arange(n)
    uB = 0.01 * np.exp(-(((x - n / 2) / width) ** 2))
    vh = -np.gradient(uB) - 0.5 * dt * (KB @ uB) / MB
    e0 = float(0.5 * vh @ (MB * vh) + 0.5 * uB @ KB @ uB)
    state = np.concatenate([uB, vh, np.zeros(3 * n + 1)])
    for _ in range(int(1.5 * n / (m * dt))):
        state = step(state)
    uB, vh, uA, vA = np.split(state[: 4 * n], 4)
    e_b = float(0.5 * vh @ (MB * vh) + 0.5 * uB @ KB @ uB)
    e_a = float(0.5 * vA @ (MA * vA) + 0.5 * uA @ KA @ uA)
    return e_b / e0, e_a / e0


def reflected(m: int, variant: str, width: float = 30.0) -> float:
    """Fraction of the pulse's energy left in the explicit chain (``pulse_balance``)."""
    return pulse_balance(m, variant, width)[0]


def long_run(m: int, method: str = "gc") -> tuple[float, float]:
    """(max E / E0, final interface-dissipated / E0) of the undamped clamped split bar."""
    exe = str(Path(sys.executable).parent / "crane-fem")
    with tempfile.TemporaryDirectory() as tmp:
        scenario = ROOT / "demos" / "split_bar_undamped.toml"
        cmd = [exe, "run", str(scenario), "-o", tmp, "--no-progress"]
        cmd += ["--set", f"coupling.ratio={m}", "--set", f"coupling.method='{method}'"]
        subprocess.run(cmd, check=False, capture_output=True)
        from crane_fem.io import read_history

        h = read_history(Path(tmp) / "history.csv")
    e = h["kinetic"] + h["internal"]
    return float(np.max(e) / e[0]), float(h["interface_dissipated"][-1] / e[0])


def main() -> int:
    cols = ["m", "ρ gc (H_j, j/m)", "ρ H constant", "ρ causal", "ρ ec", "ρ gc-mean"]
    cols += ["reflected: gc", "causal", "ec (30 el.)", "ec (90 el.)", "gc-mean"]
    cols += ["split bar max E/E0: gc", "ec", "gc-mean", "E_Γ/E0: gc", "ec", "gc-mean"]
    print("| " + " | ".join(cols) + " |")
    print("|" + "---|" * len(cols))
    for m in (1, 2, 3, 5, 10, 100):
        variants = ("jm", "const", "causal", "ec", "mean")
        row = [f"{spectral_radius(m, v):.6f}" for v in variants]
        row += [f"{reflected(m, v):.3g}" for v in ("jm", "causal", "ec")]
        row += [f"{reflected(m, 'ec', width=90.0):.3g}", f"{reflected(m, 'mean'):.3g}"]
        runs = [long_run(m, method) for method in ("gc", "ec", "gc-mean")]
        row += [f"{r[0]:.4g}" for r in runs] + [f"{r[1]:.3g}" for r in runs]
        print(f"| {m} | " + " | ".join(row) + " |")
    print("\nPH (THEORY.md §3, the package's 'ph'): nonzero |eigenvalues| of one macro step,")
    print("chains of n nodes: m, n, max, min")
    for m in (2, 10, 100):
        for n in (6, 30):
            step, _, _, _ = _macro_step(m, "ph", n, clamp=True)
            A = np.column_stack([step(e) for e in np.eye(5 * n + 1)])
            ev = np.abs(np.linalg.eigvals(A))
            ev = ev[ev > 1e-6]
            print(f"| {m} | {n} | {ev.max():.12f} | {ev.min():.12f} |")
    print("\nPulse of 30 elements crossing (physical energies / E0): m, method, explicit side")
    print("after, implicit side after")
    for m in (2, 10, 30, 100):
        for v in ("jm", "ph", "mean"):
            e_b, e_a = pulse_balance(m, v)
            print(f"| {m} | {v} | {e_b:.3g} | {e_a:.4f} |")
    print("\ngc-mean with the free implicit velocity interpolated instead of its mean: m, ρ")
    for m in (1, 2, 3, 5, 10, 100):
        print(f"| {m} | {spectral_radius(m, 'interp'):.6f} |")
    print("\nCross-check in Newmark form (hughes_growth): m, ρ, energy of the GC proof after")
    print("2000 macro steps along the dominant mode / its initial value")
    for m in (1, 2, 3, 5, 10):
        rho, growth = hughes_growth(m)
        print(f"| {m} | {rho:.6f} | {growth:.3g} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
