"""What Python gives for a 3-D export's equilibrium: the load history of :func:`esba.statics.spatial.solve3d`
followed finely enough to see where its stable branch ends, and how.

:func:`reference_history3d` raises the pressure (other loads off), then the payloads, moments and
weight, each ramp in ``steps`` equal steps of the damped Newton method of the 3-D solve
(:func:`esba.statics.spatial.newton3d`) from the previous state. A step whose state is not stable
(the 3n x 3n Hessian's smallest eigenvalue <= 0) or that moved farther than ``jump`` rad has left
the stable branch: the end is located by bisection in the load factor, the critical mode is the
Hessian's softest eigenvector there, and the state is kicked along it (along the branch's tangent
where the mode has a share in it, a fold; else both signs, the nearer landing state kept, a
branch point) and relaxed just past the end. Such an end is a ``snap`` when the state jumped,
``sideways`` when more than half of the mode's squared norm lies in psi and tau: the export's rule
(``templates/solver3d.c``), computed independently in NumPy.
"""

from __future__ import annotations

from typing import Mapping

import numpy as np

from esba.model.spatial import Model3D
from esba.statics.spatial import _bounds, load_names, newton3d

__all__ = ["reference_history3d"]

SIDEWAYS = 0.5
ALIGNED = 0.1
SNAP_PAST = 1e-7
KICK = 0.05


def _stable_newton(model, vals, q0, lb):
    q, ok, _ = newton3d(model, vals, q0, lb=lb)
    if not ok:
        return q, False
    return q, bool(np.linalg.eigvalsh(model.hessian(q, vals))[0] > 0)


def _relax(model, vals, q, lb):
    """The damped Newton method down to a stable state (past a saddle along its softest mode)."""
    for _ in range(6):
        q, ok, _ = newton3d(model, vals, q, lb=lb, max_iter=400)
        if not ok:
            return q, False
        w, V = np.linalg.eigh(model.hessian(q, vals))
        if w[0] > 0:
            return q, True
        v = V[:, 0]
        q = q + 1e-3 * (v if v[np.argmax(np.abs(v))] > 0 else -v)
    return q, False


def reference_history3d(model: Model3D, values: Mapping[str, float], steps: int = 32, jump: float = 0.5) -> dict:
    """The equilibrium along the load history: ``q``, ``status`` ('ok', 'snapped', 'buckled' or
    'failed'), the events (load factor, jumped, sideways share)."""
    values = dict(values)
    lb = _bounds(model, values)
    n = model.n
    loads = load_names(model)
    stage0 = {**values, **{k: 0.0 for k in loads}, "P": 0.0} if "P" in values else {**values, **{k: 0.0 for k in loads}}
    stage1 = {**values, **{k: 0.0 for k in loads}}
    q = np.zeros(model.size)
    events = []
    for a, b in ((stage0, stage1), (stage1, values)):
        keys = [k for k in a if a[k] != b[k]]
        if not keys:
            continue

        def at(lam):
            return {**a, **{k: a[k] + lam * (b[k] - a[k]) for k in keys}}

        lam = 0.0
        q, ok = _stable_newton(model, at(0.0), q, lb)

        def advance(q0, l0, l1):
            """Newton from the tangent predictor at l1: (state, accepted)."""
            H = model.hessian(q0, at(l0))
            dg = (model.gradient(q0, at(l0 + 1e-6)) - model.gradient(q0, at(l0 - 1e-6))) / 2e-6
            try:
                pred = q0 - (l1 - l0) * np.linalg.solve(H, dg)
            except np.linalg.LinAlgError:
                return q0, False
            qn, okn = _stable_newton(model, at(l1), pred, lb)
            moved = float(np.abs(pred - q0).max())
            return qn, bool(okn and np.abs(qn - pred).max() <= 0.5 * moved + 1e-6 and np.abs(qn - q0).max() <= jump)

        h, hmax, ends = 1.0 / steps, 1.0 / steps, 0
        while lam < 1.0:
            nxt = min(1.0, lam + h)
            qn, ok = advance(q, lam, nxt)
            if ok:
                q, lam = qn, nxt
                h = min(2 * h, hmax)
                continue
            h *= 0.5
            if h >= 1e-10:
                continue
            ends += 1  # the stable branch ends at lam
            if ends > 8:
                return {"q": q, "status": "failed", "events": events}
            lo, qlo = lam, q
            vals = at(lo)
            H = model.hessian(qlo, vals)
            w, V = np.linalg.eigh(H)
            v = V[:, 0]
            e = 1e-6
            dg = (model.gradient(qlo, at(lo + e)) - model.gradient(qlo, at(lo - e))) / (2 * e)
            t = -np.linalg.solve(H, dg)
            share = float(np.sum(v[n:] ** 2) / np.sum(v ** 2))
            past = min(1.0, lo + SNAP_PAST)
            kicks = []
            if np.abs(v @ t) > ALIGNED * np.linalg.norm(t):
                kicks = [np.sign(v @ t) * v]
            else:
                v = v if v[np.argmax(np.abs(v))] > 0 else -v
                kicks = [v, -v]
            best = None
            for kv in kicks:
                for eps in (KICK / np.sqrt(n), 4 * KICK / np.sqrt(n), 16 * KICK / np.sqrt(n)):
                    start = qlo + eps * kv
                    start[:n] = np.where(start[:n] <= lb[:n], 0.5 * (qlo[:n] + lb[:n]), start[:n])
                    ql, okl = _relax(model, at(past), start, lb)
                    if okl:
                        d = float(np.linalg.norm(ql - qlo))
                        if best is None or d < best[0]:
                            best = (d, ql)
                        break
            if best is None:
                return {"q": qlo, "status": "failed", "events": events}
            jumped = not (len(kicks) == 2 and best[0] <= KICK / np.sqrt(n))
            if jumped or share > SIDEWAYS:
                events.append({"at": past, "jumped": jumped, "side": share})
            q, lam, h = best[1], past, hmax
    q, ok = _relax(model, values, q, lb)
    if not ok:
        return {"q": q, "status": "failed", "events": events}
    status = "buckled" if any(e["side"] > SIDEWAYS for e in events) else ("snapped" if any(e["jumped"] for e in events) else "ok")
    return {"q": q, "status": status, "events": events}
