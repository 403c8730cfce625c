"""The page ``docs/3d.md``: the spatial model, its benchmarks against published values, what
sideways stiffness and twist do to the paper's actuator, and what 3-D costs (``esba docs --write 3d``)."""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from esba.bench.timing import median_time

from .page import TIMES, Page, Progress, Rendered, Times

__all__ = ["PAGE", "SpatialPage"]

#: The section stiffness pairs of the flip study (N*mm^2): the silicone alone (concentric-annulus
#: closed forms, G = E/3) and stiffer sections, as the layer and the fibres make them.
FLIP_GJ = ("silicone", 1.0e4, 1.0e5)
FLIP_EI_SIDE = ("silicone", 4.0e5)
#: Where the flip study stops (N).
FLIP_TOP = 4.0
#: The stated twist angle of the sideways-load study (degrees).
TWIST_DEG = 10.0
#: B6's torsional stiffnesses (EI = 1): a 45 deg pre-twist, and nearly rigid in torsion; and one
#: softer in torsion than in bending (rubber's round rod, GJ = 2/3 EI), which never buckles.
B6_GJ = (3.0, 1000.0)
B6_SOFT = 2.0 / 3.0


@dataclass
class SpatialData:
    restriction: dict[str, float] = field(default_factory=dict)
    b1: list[tuple] = field(default_factory=list)
    b2: float = 0.0
    b3: list[tuple] = field(default_factory=list)
    b5: tuple = ()
    b6: list[tuple] = field(default_factory=list)
    flips: list[tuple] = field(default_factory=list)
    twists: list[tuple] = field(default_factory=list)
    silicone: tuple = ()
    swung: list = field(default_factory=list)
    cost: dict[str, Any] = field(default_factory=dict)
    b6_soft: bool = False
    paths: dict[str, Any] = field(default_factory=dict)


class SpatialPage(Page):
    name = "3d"

    def compute(self, settings: None = None, progress: Progress | None = None) -> SpatialData:
        from esba.analysis import rod3d
        from esba.model.closed_form import pressure_for_angle
        from esba.model.scene import MAIN_JOB
        from esba.model.spatial import load_model3d
        from esba.statics.equilibrium import solve
        from esba.statics.spatial import equilibria3d, first_instability, fold3d, load_for_twist, newton3d, solve3d, warm3d

        say = progress or (lambda msg: None)
        d = SpatialData()
        stiff = dict(EI_side=4e5, GJ=1e6, Beta1=0.0)
        # --- the planar restriction
        say("the planar restriction")
        planar = solve(MAIN_JOB)
        m3 = load_model3d(3)
        r = solve3d(m3, {**MAIN_JOB.parameters(planar.pressure), **stiff})
        vals = {**MAIN_JOB.parameters(0.16), **stiff}
        q = solve3d(m3, vals, certify=False).q
        for P in np.linspace(0.16, 0.173, 14):
            vals["P"] = P
            q, _, _ = newton3d(m3, vals, q)
        upper = fold3d(m3, vals, "P", q)[0]
        vals = {**MAIN_JOB.parameters(0.3), **stiff}
        q = solve3d(m3, vals, certify=False).q
        vals["P"] = 0.165
        q, _, _ = newton3d(m3, vals, q)
        lower = fold3d(m3, vals, "P", q)[0]
        d.restriction = {"dtheta": float(np.abs(r.theta - planar.theta).max()), "psi_tau": float(np.abs(r.q[3:]).max()),
                         "upper": upper, "lower": lower}
        # --- B1
        say("B1 elastica")
        for alpha in (1.0, 2.0, 5.0, 10.0):
            ref = rod3d.elastica_reference(alpha)
            f8, f16 = rod3d.elastica(8, alpha), rod3d.elastica(16, alpha)
            ext = {k: rod3d.richardson(f8[k], f16[k]) for k in ref}
            d.b1.append((alpha, ref, f16, ext))
        # --- B2
        say("B2 roll-up")
        mm = load_model3d(4, "rod,moment")
        v2 = dict(L=1.0, EI=1.0, EI_side=1.0, GJ=1.0, kappa0=0.0, mx1=0.0, my1=0.0, mz1=0.0, sm1=1.0)
        q = np.zeros(mm.size)
        for lam in np.linspace(0.0, 1.0, 21)[1:]:
            v2["mz1"] = lam * 2 * np.pi
            q, _, _ = newton3d(mm, v2, q)
        d.b2 = float(np.abs(mm.tip(q, 1.0)).max())
        # --- B3
        say("B3 Bathe-Bolourchi")
        t8, t16 = rod3d.bathe_bolourchi(8), rod3d.bathe_bolourchi(16)
        for P, refs in rod3d.BATHE_REFERENCES.items():
            d.b3.append((P, t8[P], rod3d.richardson(t8[P], t16[P]), refs))
        # --- B5
        say("B5 Prandtl")
        b8, b16 = rod3d.lateral_torsional_load(8), rod3d.lateral_torsional_load(16)
        d.b5 = (b8.load / rod3d.PRANDTL, b16.load / rod3d.PRANDTL, rod3d.richardson(b8.load, b16.load) / rod3d.PRANDTL)
        # --- B6
        say("B6 twist buckling under an end couple")
        for GJ in B6_GJ:
            T, phi0, M = rod3d.greenhill_reference(1.0, GJ)
            c8, c16 = rod3d.twist_buckling_couple(8, GJ=GJ), rod3d.twist_buckling_couple(16, GJ=GJ)
            d.b6.append((GJ, M, np.degrees(phi0), c8.load, c16.load, rod3d.richardson(c8.load, c16.load)))
        d.b6_soft = rod3d.twist_buckling_couple(8, GJ=B6_SOFT, top=40.0) is None
        # --- the paper's actuator: a push in the bending plane until it flips
        say("the flip study")
        E, r1, r2 = MAIN_JOB.actuator.E, MAIN_JOB.actuator.r1, MAIN_JOB.actuator.r2
        Ic = np.pi * (r1**4 - r2**4) / 4
        silicone = {"GJ": E / 3 * 2 * Ic, "EI_side": E * Ic}
        d.silicone = (silicone["EI_side"], silicone["GJ"])
        d.swung = [(s.energy, s.morse_index, s.in_plane, tuple(float(v) for v in s.tip)) for s in equilibria3d(MAIN_JOB, silicone)]
        P90 = pressure_for_angle(MAIN_JOB.unloaded())
        for GJ in FLIP_GJ:
            for EIs in FLIP_EI_SIDE:
                gj = silicone["GJ"] if GJ == "silicone" else GJ
                eis = silicone["EI_side"] if EIs == "silicone" else EIs
                vals = {**MAIN_JOB.parameters(P90), "EI_side": eis, "GJ": gj, "F1": 0.0, "Beta1": 0.0}
                q0 = solve3d(m3, vals, certify=False).q
                found = first_instability(m3, vals, "F1", q0, top=FLIP_TOP)
                if found is None:
                    d.flips.append((eis, gj, None, None, None))
                else:
                    F, qs, mode = found
                    d.flips.append((eis, gj, F, float(np.degrees(np.sum(qs[:3]))), float(np.abs(mode[:3]).max())))
                side = {**vals, "Omega1": 0.0, "Beta1": np.pi / 2}  # a tip load straight out of the plane (+z)
                qs0 = solve3d(m3, side, certify=False).q
                hit = load_for_twist(m3, side, "F1", qs0, angle=np.radians(TWIST_DEG), top=FLIP_TOP)
                d.twists.append((eis, gj, None if hit is None else hit[0], None if hit is None else float(m3.tip(hit[1], side["L"])[2])))
        # --- paths and every equilibrium in 3-D (esba path --3d, esba equilibria --3d)
        say("3-D paths")
        from esba.analysis.path3d import analyse3d, split_angles
        from esba.paths.continuation import trace
        from esba.statics.spatial_paths import SpatialPathProblem
        from esba.statics.spatial_search import search3d

        rod8 = load_model3d(8, "rod,payload")
        problem = SpatialPathProblem.from_values(rod8, rod3d.rod_values(EI=1e6, F=0.0, Omega=np.pi / 2), "payload")
        (bp,) = trace(problem, np.zeros(rod8.size), 0.0, to=6.0).branch_points
        d.paths["b5"] = (bp.lam, bp.bifurcation, bp.status, abs(bp.lam / b8.load - 1.0))
        flip = analyse3d(MAIN_JOB, "payload", 2.0, start=0.0)
        (bp,) = flip.main.branch_points
        ends = [(b.label, float(b.lam[-1]), bool(np.all(b.stable[len(b) // 2:])), split_angles(b.theta[-1], 3), tuple(float(v) for v in b.tip[-1]))
                for b in flip.crossing]
        up, down = flip.loading
        d.paths["flip"] = {"bp": bp.lam, "kind": bp.bifurcation, "angle": split_angles(bp.theta, 3)[0], "ends": sorted(ends),
                           "section": (flip.section["EI_side"], flip.section["GJ"]), "up_reached": up.reached, "up_jumps": len(up.jumps),
                           "up_crossed": [s.lam for s in up.branch_points], "down_reached": down.reached, "down_jumps": len(down.jumps),
                           "down_crossed": [s.lam for s in down.branch_points]}
        found = search3d(MAIN_JOB, starts=4)
        d.paths["search"] = {"complete": found.complete, "states": [(s.stability, s.energy, s.angles_deg(), tuple(float(v) for v in s.tip), s.certified)
                                                                   for s in found.states]}
        # --- cost
        say("cost")
        from esba.derive.emit3d import generate_source3d
        from esba.derive.effects3d import Effects3D
        from esba.model.generated import load_model

        gen = {}
        for n in (3, 10, 30):
            t0 = time.perf_counter()
            _, entry = generate_source3d(n, Effects3D.parse("air,axial,radial,fibres,payload"))
            gen[n] = (time.perf_counter() - t0, entry["_assignments"], entry["instructions"]["hessian"])
        v3 = {**MAIN_JOB.parameters(planar.pressure), **stiff}
        d.cost = {
            "generation": gen,
            "solve3d_n3": median_time(lambda: solve3d(m3, v3), 5),
            "solve_planar_n3": median_time(lambda: solve(MAIN_JOB), 5),
        }
        m30 = load_model3d(30)
        v30 = dict(v3)
        q30 = solve3d(m30, v30, certify=False).q
        warm3d(m30, v30, q30 + 1e-6)  # builds its Newton kernel once
        d.cost["warm_n30"] = median_time(lambda: warm3d(m30, v30, q30 + 1e-6), 11)
        load_model(3)
        return d

    def render(self, d: SpatialData, settings: None, path: Path, times: Times = TIMES) -> Rendered:
        from esba.derive.effects3d import COORDINATES  # noqa: F401  (documented below)

        R = d.restriction
        out = [
            "# The actuator in 3-D",
            "",
            "<!-- Written by `esba docs --write 3d` (esba/pages/spatial.py); do not edit by hand. -->",
            "",
            "The paper closes with its next step: the 3-D deformation under payloads anywhere along the actuator. esba's spatial model",
            "family (`derive/spatial.py`, `derive/program3d.py`, emitted by `derive/emit3d.py` as `generated/m3d_*.py`) gives every",
            "joint three rotations: the paper's in-plane bend theta_i (about z), a sideways bend psi_i (about y) and a twist tau_i",
            "(about the tangent x). Solve with `esba solve --3d --section EI_side=... --section GJ=...` (chosen by itself when a",
            "payload points out of the plane: `--payload-out-of-plane DEG`, `out_of_plane_deg` in a scene file) or",
            "`esba.statics.spatial.solve_scene3d`. `--plot FILE` draws the deformed actuator as a tube with its chamber side",
            "marked and the payloads as arrows (`esba/figures/spatial.py`); `--html FILE.html` writes the same view as one",
            "offline page that turns with the mouse.",
            "",
            "## The derivation in short",
            "",
            "- Kinematics: Eq. (1)-(2) on SE(3). Segment i is exp(hat(Xi_i)) with Xi_i = [L/n, 0, 0, tau_i, psi_i, theta_i]; with",
            "  psi = tau = 0 this is the paper's twist xi_i theta_i = [l_i theta_i, 0, 0, 0, 0, theta_i] (checked symbolically in",
            "  `tests/derive/test_spatial.py`). Each segment is a piece of a helix: inextensible and unshearable, like the layer.",
            "- The exponential in closed form (A = I + f1 W + f2 W^2, translation V (L/n) e_x, V = I + f2 W + f3 W^2, the SO(3) left",
            "  Jacobian); f1, f2, f3 are series below |w| = 1 and closed forms above, so value, gradient and Hessian are exact at",
            "  straight segments.",
            "- Energies: the paper's in-plane terms (air, axial, radial, fibres) of `derive/energy.py` verbatim in theta_i, plus",
            "  1/2 EI_side (n/L) psi_i^2 and 1/2 GJ (n/L) tau_i^2. The plain rod replaces the paper's terms by 1/2 EI (n/L) (theta_i -",
            "  kappa0 L/n)^2.",
            "- Loads: a payload F (cos B cos Omega, -cos B sin Omega, sin B) at any fraction s of L (B = 0 is Eq. 14); gravity",
            "  along any (gx, gy, gz); and two kinds of point moment (`[[moments]]` in a scene file, `--moment MX,MY,MZ`,",
            "  `esba.model.scene.Moment`). With an arm (`arm = [ax, ay, az]`, `--moment-arm`) it is a *couple*: dead forces -f at",
            "  the section's centre and +f at the centre plus the arm e, f = (m x e)/|e|^2 fixed in space, e turning with the",
            "  section; potential -f . (R(s) e - e), its moment m at the straight state. It is a physical load at any rotation (a",
            "  lever with weights on pulleys), conservative, and its load stiffness is what twist-buckles a shaft (B6). Without an",
            "  arm, a generalised force on the joint rotations, potential -m . sum_i sigma_i (tau_i, psi_i, theta_i): exact for a",
            "  moment about the layer's normal z bending the actuator in its plane (a constant bending moment: B2), and the body",
            "  moment to first order in the sideways bend and twist, so for its other components only while they stay small. A",
            "  moment fixed in space, or one that follows the section, is not conservative in 3-D and has no potential.",
            "- Gradient and Hessian by the screw-form Jacobian of the chain (each entry O(1), cumulative poses as symbols):",
            "  off the diagonal, d2U/dq_{j,a} dq_{k,b} = Omega_{j,a} . (sum over loads of D_{k,b} x w), one 3-term dot product.",
            "",
            "## The planar model is the restriction of the 3-D one",
            "",
            f"- Table 2 (2 N horizontal at the tip, n = 3) in 3-D: largest |theta_3D - theta_planar| = {R['dtheta']:.1e} rad; sideways",
            f"  bend and twist {R['psi_tau']:.1e}.",
            f"- The 2 N pressure folds found by the 3-D model (Newton on its extended system): {R['upper']:.12f} MPa and",
            f"  {R['lower']:.12f} MPa (planar: 0.173535495546 and 0.163601780422).",
            "- At every in-plane state the 3-D energy, gradient and theta-theta Hessian block are the planar ones and the blocks",
            "  coupling theta to psi and tau vanish (tested at n = 1, 2, 3), so every planar fold, cusp and buckling load is one of",
            "  the 3-D model too.",
            "",
            "## Benchmarks on the plain rod",
            "",
            "The n -> infinity limit: the chain of constant-curvature segments converges as 1/n^2; Richardson's extrapolation",
            "(4 f(16) - f(8)) / 3 removes the leading term.",
            "",
            "**B1, the elastica under a tip dead load** (Mattiasson 1981; the reference is the elliptic-integral solution by",
            "quadrature, `esba/analysis/rod3d.py`, which reproduces his table to its 5 digits):",
            "",
            "| alpha = PL^2/EI | v/L ref | u/L ref | tip angle ref | n = 16: largest error | extrapolated: largest error |",
            "|---|---|---|---|---|---|",
        ]
        for alpha, ref, f16, ext in d.b1:
            e16 = max(abs(f16[k] - ref[k]) for k in ref)
            eex = max(abs(ext[k] - ref[k]) for k in ref)
            out.append(f"| {alpha:g} | {ref['v']:.5f} | {ref['u']:.5f} | {ref['phi0']:.5f} | {e16:.1e} | {eex:.1e} |")
        out += [
            "",
            f"**B2, roll-up to a full circle** under M = 2 pi EI / L by continuation in M (20 steps, n = 4): the tip returns to the",
            f"base within {d.b2:.1e} L (the chain of arcs is exact for a circle at any n).",
            "",
            "**B3, the Bathe-Bolourchi 45 degree bend** (R = 100, E = 1e7, G = E/2, I = 1/12, J = 1/6; tip load out of the plane;",
            "tip (x, y, z) in the references' axes):",
            "",
            "| P | esba n = 8 | esba extrapolated | published |",
            "|---|---|---|---|",
        ]
        for P, t8, ext, refs in d.b3:
            pub = "; ".join(f"{k} ({', '.join(f'{v:g}' for v in val)})" for k, val in refs.items())
            out.append(f"| {P:g} | ({', '.join(f'{v:.2f}' for v in t8)}) | ({', '.join(f'{v:.2f}' for v in ext)}) | {pub} |")
        out += [
            "",
            "**Cross-check against Exudyn** (`tests/analysis/test_exudyn_crosscheck.py`): Exudyn's geometrically exact beam",
            "(`ObjectBeamGeometricallyExact`, 2 nodes, constant strain per element; axial and shear stiffness 1e6 EI/L^2) with the",
            "same EI, EI_side and GJ, on a rod with a sideways tip load (bend in two planes and twist) and on the elastica: the tips",
            "agree within 5e-6 L at equal n (3, 8, 16), the two codes discretising the rod the same way; and on B3 at P = 300 with",
            "8 segments and 8 elements within 5e-3 (Exudyn converges there only with its penalty lowered to 1e5 EI/L^2, which lets",
            "the tip move that much more; it takes about 15 s, at P = 600 minutes, so the test stops at 300).",
        ]
        b8, b16, bex = d.b5
        out += [
            "",
            "**B5, Prandtl's lateral-torsional buckling** of a cantilever loaded at its tip in its stiff plane (EI = 1e6 EI_side):",
            f"the branch point (the 3n x 3n Hessian singular, its mode sideways bend and twist) at {b8:.5f} (n = 8), {b16:.5f}",
            f"(n = 16) and {bex:.6f} (extrapolated) times 4.0126 sqrt(EI_side GJ) / L^2.",
            "",
            "**B6, twist buckling under an end torque** (Greenhill's problem on a cantilever): an isotropic rod (EI both ways) with",
            "the couple of dead forces on a rigid arm at its tip (arm along y, forces along z: a torque M about the axis at the",
            "straight state). The couple twists it by phi0 with GJ phi0 / L = M cos phi0; linearising the bending of the twisted",
            "rod about that state (the internal moment is the couple's, constant along the rod; its arm turns with the tip) gives",
            "z' = i k z for z = (v' - v'(L) - tan(phi0) w'(L)) + i w', k = M cos(phi0) / EI, with v'(0) = w'(0) = 0, so a",
            "nontrivial solution needs k L = pi/2 + phi0: T_cr = M cos(phi0) = (pi / 2L) EI GJ / (GJ - EI), which tends to the",
            "classical pi EI / 2L as GJ -> infinity and does not exist for GJ <= EI (the twist runs to 90 deg first). esba finds",
            "it as a branch point (the Hessian singular on the twisted state; `esba.analysis.rod3d.twist_buckling_couple`):",
            "",
            "| GJ / EI | pre-twist phi0 (deg) | closed form M_cr L / EI | n = 8 | n = 16 | extrapolated | relative error |",
            "|---|---|---|---|---|---|---|",
            *[f"| {gj:g} | {phi:.3f} | {M:.6f} | {m8:.6f} | {m16:.6f} | {mex:.6f} | {abs(mex / M - 1):.1e} |" for gj, M, phi, m8, m16, mex in d.b6],
            "",
            f"With GJ = {B6_SOFT:.3g} EI (rubber's round rod, G = E/3, J = 2I) the twisted state "
            f"{'stays stable up to M = 40 EI/L: the end couple never buckles it' if d.b6_soft else '**buckles**, against the closed form'}.",
            "",
            "## Sideways stiffness and twist for a gripper finger",
            "",
            "The paper's actuator bends in its plane because the layer blocks the axial strain on one side; nothing in the planar",
            "model says how it resists a load out of that plane, or a push that makes it turn about its own base. In 3-D the",
            "Table 1 actuator at its 90 degree pressure, pushed at its tip against the bending direction (the Table 2 load), keeps",
            "its in-plane shape only while the push is below the load at which its Hessian loses a sideways-twist mode:",
            "",
            "| EI_side (N mm^2) | GJ (N mm^2) | push that flips it (N) | total angle there (deg) | in-plane part of the mode |",
            "|---|---|---|---|---|",
        ]
        for eis, gj, F, ang, inplane in d.flips:
            if F is None:
                out.append(f"| {eis:.4g} | {gj:.4g} | stable to {FLIP_TOP:g} N | | |")
            else:
                out.append(f"| {eis:.4g} | {gj:.4g} | {F:.4f} | {ang:.2f} | {inplane:.1e} |")
        out += [
            "",
            f"A tip load straight out of the plane (Beta = 90 deg) on the same actuator twists it; the load at which the total",
            f"twist sum(tau_i) reaches {TWIST_DEG:g} deg:",
            "",
            "| EI_side (N mm^2) | GJ (N mm^2) | sideways tip load for the twist (N) | tip z there (mm) |",
            "|---|---|---|---|",
        ]
        for eis, gj, F, z in d.twists:
            out.append(f"| {eis:.4g} | {gj:.4g} | " + (f"below {TWIST_DEG:g} deg up to {FLIP_TOP:g} N | |" if F is None else f"{F:.4f} | {z:.2f} |"))
        out += [
            "",
            f"\"silicone\" is the rubber alone as a concentric annulus (EI_side = E pi (r1^4 - r2^4)/4 = {d.silicone[0]:.4g},",
            f"GJ = (E/3) pi (r1^4 - r2^4)/2 = {d.silicone[1]:.4g} N mm^2): with those, 2 N (Table 2) is far past the flip, so the",
            "paper's 2 N experiment stays in its plane only because the layer and the double-helix fibres make the finger stiff",
            "in torsion. The mode is a swing of the whole bent finger about its base (twist), not a buckle in the plane (its",
            "in-plane part is 0). For a gripper this is the number to design against: a finger that holds an object by pushing",
            "on it must carry GJ well above the silicone's. Where it goes: `equilibria3d` (the planar search for the in-plane",
            "states, then down their out-of-plane modes) finds for Table 2 with the silicone's stiffnesses",
            "",
            "| energy (N mm) | Morse index | in the plane | tip (x, y, z) mm |",
            "|---|---|---|---|",
            *[f"| {e:.4f} | {m} | {'yes' if ip else 'no'} | ({', '.join(f'{v:.2f}' for v in tip)}) |" for e, m, ip, tip in d.swung],
            "",
            "a mirror pair of stable states swung out of the plane, and the planar state as a saddle. The section's stiffnesses",
            "(`esba section`, from the eccentric chamber,",
            "the layer and the fibres) replace these assumed pairs once given.",
            "",
            "## Paths and every equilibrium in 3-D",
            "",
            "`esba path --3d` traces the 3-D equilibria on the planar path engine (pseudo-arclength continuation; folds and",
            "branch points located by their extended systems; branch switching): `esba.statics.spatial_paths.SpatialPathProblem`",
            "hands the engine g, H and dg/dlambda of the 3n unknowns and its own corrector kernel (one Newton step on the bordered",
            "system by a dense LDL^T, whose pivots give the Morse index).",
            "",
        ]
        if d.paths:
            lam, kind, status, diff = d.paths["b5"]
            f = d.paths["flip"]
            out += [
                f"- **B5 on the path engine**: tracing the rod (n = 8) in its tip load from 0, the engine finds one branch point at",
                f"  {lam:.6f} sqrt(EI_side GJ) / L^2 ({kind}, {status}; the in-plane branch loses a sideways-twist mode), the",
                f"  value Brent's method on the smallest eigenvalue gives above to {'< 1e-6' if diff < 1e-6 else format(diff, '.1e')} (relative).",
                f"- **The paper's actuator flips sideways** under the Table 2 push with the eccentric section's stiffnesses (`esba section`:",
                f"  EI_side = {f['section'][0]:.5g}, GJ = {f['section'][1]:.5g} N mm^2; `esba path --3d --param payload --from 0 --to 2`): the",
                f"  in-plane branch has a branch point at {f['bp']:.4f} N ({f['kind']}; total angle {f['angle']:.2f} deg there) and is unstable",
                "  past it; the two branches crossing there, traced to 2 N:",
                "",
                "| branch | stable | in-plane / sideways / twist at 2 N (deg) | tip (x, y, z) mm |",
                "|---|---|---|---|",
                *[f"| {label} | {'yes' if ok else 'no'} | {a[0]:.2f} / {a[1]:.2f} / {a[2]:.2f} | ({', '.join(f'{v:.2f}' for v in tip)}) |"
                  for label, _, ok, a, tip in f["ends"]],
                "",
                "  Loaded quasi-statically from 0 to 2 N the actuator " + ("passes the branch point at " + ", ".join(f"{x:.4f}" for x in f["up_crossed"])
                                                                        + " N and goes on along a stable sideways branch" if f["up_crossed"] else "does not pass a branch point")
                + (" without a jump" if not f["up_jumps"] else f" with {f['up_jumps']} jump(s)")
                + ("; unloaded back to 0 it returns along that branch to the branch point" + (" and on along the in-plane one" if f["down_crossed"] else "")
                   + (", without a jump." if not f["down_jumps"] else f", with {f['down_jumps']} jump(s).") if f["down_reached"] else "; unloaded, it does NOT get back to 0."),
                "- **Every equilibrium at 2 N** (`esba equilibria --3d`: deflated Newton in the 3n unknowns from the planar states,",
                "  their unstable modes and a grid; " + ("the completeness check from fresh starts found nothing new):" if d.paths["search"]["complete"] else "the completeness check found more):"),
                "",
                "| stability | energy (N mm) | in-plane / sideways / twist (deg) | tip (x, y, z) mm | certified |",
                "|---|---|---|---|---|",
                *[f"| {st} | {e:.4f} | {a[0]:.2f} / {a[1]:.2f} / {a[2]:.2f} | ({', '.join(f'{v:.2f}' for v in tip)}) | {'yes' if c else 'no'} |"
                  for st, e, a, tip, c in d.paths["search"]["states"]],
                "",
                "  The in-plane state of the planar model is a saddle here; the finger settles in one of the two mirror states, turned",
                "  over (its twist near 160 degrees) with the tip on the other side of the plane's vertical.",
                "",
            ]
        out += [
            "## What 3-D costs",
            "",
            "| n | generation (s) | assignments | Hessian instructions |",
            "|---|---|---|---|",
        ]
        for n, (t, a, h) in d.cost["generation"].items():
            out.append(f"| {n} | {times(t, '.1f')} | {a} | {h} |")
        c = d.cost
        out += [
            "",
            "Generation grows about linearly in the assignments (the Hessian's O(n^2) entries are references, one dot product each).",
            f"A 3-D solve at n = 3 (load history and IPOPT certificate): {times(c['solve3d_n3'] * 1e3, '.1f')} ms against",
            f"{times(c['solve_planar_n3'] * 1e3, '.1f')} ms for the planar `solve` of the same scene; a warm 3-D solve (`warm3d`) at",
            f"n = 30 (90 unknowns): {times(c['warm_n30'] * 1e3, '.2f')} ms. Targets (issue 26): a 3-D solve at n = 3 within 2x of the",
            "planar one; warm n = 30 <= 2 ms; generation at n = 30 <= 30 s.",
            "",
        ]
        return Rendered("\n".join(out))


PAGE = SpatialPage()
