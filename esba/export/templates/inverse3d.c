/* ---------------------------------------------------------------- the pressure for a total angle */

/* Newton on the bordered system g(q, P) = 0, sum(theta) = target from (q, *P) (in place):
 * H dq + dg/dP dP = -g, sum(dtheta) = target - sum(theta). Returns 1 when it converged;
 * *contraction as newton()'s. */
static int bordered(WORK *w, const {{NAME}}_params *a, {{NAME}}_loads *lp, REAL *q, REAL *P, REAL target, REAL *contraction) {
    REAL first = RC(0.0);
    int it, k;
    *contraction = RC(0.0);
    for (it = 0; it < MAX_NEWTON; ++it) {
        REAL ea = RC(0.0), eb = RC(0.0), r, dP, size, f;
        lp->pressure = *P;
        pack(a, lp, RC(1.0), RC(1.0), w->p);
        if (!eval_tangent(w, q, w->p, w->unit, w->gl) || !eval_newton(w, q, w->p) || !factor(w, RC(0.0))) return 0;
        solve(w, w->g, w->x);
        solve(w, w->gl, w->y);
        for (k = 0; k < N; ++k) {
            ea += w->x[k];
            eb += w->y[k];
        }
        if (!(FABS(eb) > 0) || !isfinite(eb)) return 0;
        r = sum_n(q) - target;
        dP = (r - ea) / eb;
        for (k = 0; k < NQ; ++k) w->x[k] = w->x[k] + w->y[k] * dP; /* -dq */
        size = max_abs(w->x, NQ);
        if (!isfinite(size) || !isfinite(dP)) return 0;
        if (it == 0) first = size;
        if (it == 1 && first > TINY) *contraction = size / first;
        f = fraction_inside(w, q, w->x);
        for (k = 0; k < NQ; ++k) q[k] -= f * w->x[k];
        *P += f * dP;
        w->iterations++;
        if (f == RC(1.0) && size <= STEP_TOL) return 1;
    }
    lp->pressure = *P;
    pack(a, lp, RC(1.0), RC(1.0), w->p);
    if (!eval_newton(w, q, w->p)) return 0;
    return max_abs(w->g, NQ) <= GRAD_TOL && FABS(sum_n(q) - target) <= ANGLE_TOL;
}

int {{NAME}}_pressure_for_angle(int n, const {{NAME}}_params *a, const {{NAME}}_loads *l, REAL total, REAL pmax, const {{NAME}}_state *from,
                                {{NAME}}_result *out, WORK *w) {
    {{NAME}}_loads lp;
    {{NAME}}_result check;
    REAL P, h = ANGLE_STEP, contraction;
    int status = begin(n, a, l, out, w), step, k, reached = 0, multistable;
    if (status != ESBA_OK) return done(out, status);
    if (!isfinite(total) || !isfinite(pmax) || !(pmax >= 0)) return done(out, ESBA_BAD_INPUT);
    status = check_from(w, from);
    if (status != ESBA_OK) return done(out, status);
    lp = *l;
    if (from != NULL) {
        if (!(from->loads.pressure <= pmax)) return done(out, ESBA_BAD_INPUT);
        lp.pressure = from->loads.pressure;
        status = history(w, a, &lp, from, out);
    } else {
        lp.pressure = RC(0.0);
        status = history(w, a, &lp, NULL, out);
    }
    if (status != ESBA_OK) {
        pack(a, &lp, RC(1.0), RC(1.0), w->p);
        finish(w, a, &lp, w->lo, lp.pressure, out);
        return done(out, status);
    }
    P = lp.pressure;
    for (k = 0; k < NP; ++k) w->unit[k] = RC(0.0);
    w->unit[{{IDX_P}}] = RC(1.0);
    for (step = 0; step < MAX_STEPS; ++step) {
        REAL now = sum_n(w->lo), target, Pt;
        if (FABS(now - total) <= ANGLE_TOL) {
            reached = 1;
            break;
        }
        target = total > now ? (now + h < total ? now + h : total) : (now - h > total ? now - h : total);
        copy(w->trial, w->lo, NQ);
        Pt = P;
        if (bordered(w, a, &lp, w->trial, &Pt, target, &contraction) && contraction <= CONTRACTION && Pt >= 0 && Pt <= pmax &&
            max_diff(w->trial, w->lo) <= MAX_DQ && eval_newton(w, w->trial, w->p) && factor(w, RC(0.0)) && w->rel > CRITICAL_TOL) {
            copy(w->lo, w->trial, NQ);
            P = Pt;
            out->steps++;
            if (contraction < RC(0.1)) h = RC(2.0) * h < ANGLE_STEP ? RC(2.0) * h : ANGLE_STEP;
            continue;
        }
        h *= RC(0.5);
        if (h < ANGLE_TOL) break;
    }
    lp.pressure = P;
    /* the load history at the pressure found: does it reach this state? */
    copy(out->q, w->lo, NQ);
    k = w->iterations;
    status = {{NAME}}_equilibrium(n, a, &lp, NULL, &check, w);
    multistable = (status == ESBA_OK || status == ESBA_SNAPPED || status == ESBA_BUCKLED) && max_diff(check.q, out->q) > LOAD_PATH_TOL;
    w->iterations += k;
    copy(w->lo, out->q, NQ);
    pack(a, &lp, RC(1.0), RC(1.0), w->p);
    status = finish(w, a, &lp, w->lo, P, out);
    if (multistable) out->flags |= ESBA_FLAG_MULTISTABLE;
    if (status != ESBA_OK) return done(out, status);
    return done(out, reached ? ESBA_OK : ESBA_UNREACHABLE);
}
