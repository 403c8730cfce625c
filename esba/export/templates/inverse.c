/* ---------------------------------------------------------------- the pressure for a total angle */

#define IDX_P {{IDX_P}} /* the pressure's place in the parameter vector */
#define HOLD_TOL RC({{HOLD_TOL}})

/* Newton on the bordered system dU/dtheta(theta, P) = 0, sum(theta) = angle from (theta, *pressure),
 * in place. U is linear in P, so dg/dP is exact from the tangent along w->unit. Each step costs two
 * O(n) solves with H (block elimination). Returns 1 when converged; *contraction as newton(). */
static int bordered(WORK *w, REAL *theta, REAL *pressure, REAL angle, REAL *contraction) {
    REAL first = RC(0.0), previous = RC(0.0);
    int it;
    *contraction = RC(0.0);
    for (it = 0; it < MAX_NEWTON; ++it) {
        REAL s1, s2, dp, size, f;
        int k;
        w->p[IDX_P] = *pressure;
        if (!eval_tangent(w, theta, w->p, w->unit, w->gl) || !eval_newton(w, theta, w->p) || !factor(w, RC(0.0))) return 0;
        solve(w, w->g, w->x);
        solve(w, w->gl, w->y);
        s1 = sum(w->x);
        s2 = sum(w->y);
        if (!isfinite(s2) || s2 == 0) return 0;
        /* H dtheta + g_P dP = -g, sum(dtheta) = angle - sum(theta): dtheta = -(x + dP y) */
        dp = (sum(theta) - angle - s1) / s2;
        for (k = 0; k < N; ++k) w->x[k] += dp * w->y[k];
        size = max_abs(w->x, N);
        if (!isfinite(size) || !isfinite(dp)) return 0;
        if (it == 0) first = size;
        if (it == 1 && first > TINY) *contraction = size / first;
        f = fraction_inside(w, theta, w->x);
        for (k = 0; k < N; ++k) theta[k] -= f * w->x[k];
        *pressure += f * dp;
        w->iterations++;
        if (f == RC(1.0) && size <= STEP_TOL) return 1;
        if (it > 0 && f == RC(1.0) && size <= RC(1e3) * STEP_TOL && size > RC(0.5) * previous) return 1;
        previous = size;
    }
    return 0;
}

/* One step along the branch in the total angle, from (theta, *pressure) at angle a0 to a1:
 * tangent predictor (d theta/d angle = y / sum(y), dP/d angle = -1 / sum(y), H y = g_P), bordered
 * corrector; accepted with a contracting corrector and a bounded change. theta, *pressure move
 * only when it is accepted. */
static int angle_step(WORK *w, REAL *theta, REAL *pressure, REAL a0, REAL a1) {
    REAL s2, pt, contraction;
    int k;
    w->p[IDX_P] = *pressure;
    if (!eval_tangent(w, theta, w->p, w->unit, w->gl) || !eval_newton(w, theta, w->p) || !factor(w, RC(0.0))) return 0;
    solve(w, w->gl, w->y);
    s2 = sum(w->y);
    if (!isfinite(s2) || s2 == 0) return 0;
    for (k = 0; k < N; ++k) {
        w->trial[k] = theta[k] + (a1 - a0) * w->y[k] / s2;
        if (w->trial[k] <= w->lb) w->trial[k] = RC(0.5) * (theta[k] + w->lb);
    }
    pt = *pressure - (a1 - a0) / s2;
    if (!bordered(w, w->trial, &pt, a1, &contraction) || contraction > CONTRACTION || max_diff(w->trial, theta) > MAX_DTHETA) return 0;
    copy(theta, w->trial, N);
    *pressure = pt;
    return 1;
}

/* A converged point of the branch that the answer may be: held (stable with a margin: its smallest
 * pivot above HOLD_TOL of the largest, so that the nearest reachable state located next to a fold is
 * still clearly stable, not critical), 0 <= P <= pmax. */
static int admissible(WORK *w, const REAL *theta, REAL pressure, REAL pmax) {
    w->p[IDX_P] = pressure;
    if (!eval_newton(w, theta, w->p) || !factor(w, RC(0.0))) return 0;
    return w->rel > HOLD_TOL && pressure >= 0 && pressure <= pmax;
}

/* Whether the load history at the pressure found (inflated with the payloads off, then loaded: what
 * {{NAME}}_equilibrium does) reaches the answer in out: when it does not, the actuator is multistable
 * there and the answer is held only when it is reached some other way (past a snap, along the branch).
 * out keeps its counts of the walk (the history's Newton iterations are added). */
static int on_load_path(WORK *w, const {{NAME}}_params *a, const {{NAME}}_loads *payloads, REAL pressure, {{NAME}}_result *out) {
    {{NAME}}_loads at = *payloads;
    int steps = out->steps, snaps = out->snaps, ramp_id = out->snap_ramp, status;
    REAL snap_at = out->snap_at, snap_from = out->snap_from, snap_to = out->snap_to;
    at.pressure = pressure;
    status = history(w, a, &at, NULL, out);
    out->steps = steps;
    out->snaps = snaps;
    out->snap_ramp = ramp_id;
    out->snap_at = snap_at;
    out->snap_from = snap_from;
    out->snap_to = snap_to;
    out->iterations = w->iterations;
    return status == ESBA_OK && max_diff(w->lo, out->theta) <= LOAD_PATH_TOL;
}

int {{NAME}}_pressure_for_angle(int n, const {{NAME}}_params *a, const {{NAME}}_loads *l, REAL total, REAL pmax, const {{NAME}}_state *from,
                                {{NAME}}_result *out, WORK *w) {
    {{NAME}}_loads start;
    REAL pressure, angle, h = ANGLE_STEP, dir, best_gap, best_p, in_p;
    int status, k, step, adm, have_best;
    if (l == NULL) return ESBA_BAD_INPUT;
    start = *l;
    start.pressure = from != NULL ? from->loads.pressure : RC(0.0);
    status = begin(n, a, &start, out, w);
    if (status != ESBA_OK) return status;
    if (!isfinite(total) || !isfinite(pmax) || !(pmax > 0)) return ESBA_BAD_INPUT;
    status = check_from(w, from);
    if (status != ESBA_OK) return status;
    /* the start: the equilibrium under the payloads at P = 0 (or from's pressure) */
    status = history(w, a, &start, from, out);
    pack(a, &start, RC(1.0), RC(1.0), w->p);
    if (status != ESBA_OK) {
        finish(w, a, &start, w->lo, start.pressure, out);
        return status;
    }
    for (k = 0; k < NP; ++k) w->unit[k] = RC(0.0);
    w->unit[IDX_P] = RC(1.0);
    pressure = start.pressure;
    angle = sum(w->lo);
    adm = admissible(w, w->lo, pressure, pmax);
    have_best = adm;
    best_gap = FABS(total - angle);
    best_p = pressure;
    copy(w->best, w->lo, N);
    dir = total > angle ? RC(1.0) : RC(-1.0);
    /* walk the branch in the total angle, noting the admissible point nearest to the target */
    for (step = 0; step < MAX_STEPS && angle != total; ++step) {
        REAL next = angle + dir * h, keep_p = pressure, in_a, out_a;
        int nadm, b;
        if (dir * (next - total) > 0) next = total;
        copy(w->keep, w->lo, N);
        if (!angle_step(w, w->lo, &pressure, angle, next)) {
            h *= RC(0.5);
            if (h < ANGLE_TOL) break; /* the branch turns back in the angle, or meets the domain's edge */
            continue;
        }
        out->steps++;
        nadm = admissible(w, w->lo, pressure, pmax);
        if (nadm != adm) {
            /* locate the end of the admissible stretch between the two points by bisection */
            if (adm) {
                copy(w->v, w->keep, N);
                in_p = keep_p;
                in_a = angle;
                out_a = next;
            } else {
                copy(w->v, w->lo, N);
                in_p = pressure;
                in_a = next;
                out_a = angle;
            }
            for (b = 0; b < MAX_BISECT && FABS(out_a - in_a) > BISECT_TOL; ++b) {
                REAL mid = RC(0.5) * (in_a + out_a), mid_p = in_p;
                copy(w->t, w->v, N);
                if (!angle_step(w, w->t, &mid_p, in_a, mid)) break;
                if (admissible(w, w->t, mid_p, pmax)) {
                    copy(w->v, w->t, N);
                    in_a = mid;
                    in_p = mid_p;
                } else {
                    out_a = mid;
                }
            }
            if (FABS(total - in_a) < best_gap || !have_best) {
                best_gap = FABS(total - in_a);
                best_p = in_p;
                copy(w->best, w->v, N);
                have_best = 1;
            }
        }
        if (nadm && (FABS(total - next) < best_gap || !have_best)) {
            best_gap = FABS(total - next);
            best_p = pressure;
            copy(w->best, w->lo, N);
            have_best = 1;
        }
        angle = next;
        adm = nadm;
        if (pressure > RC(2.0) * pmax || pressure < -pmax) break; /* far outside the pressures allowed */
        h = RC(2.0) * h < ANGLE_STEP ? RC(2.0) * h : ANGLE_STEP;
    }
    if (angle == total && adm) {
        w->p[IDX_P] = pressure;
        status = finish(w, a, &start, w->lo, pressure, out);
        if (status == ESBA_OK && !on_load_path(w, a, &start, pressure, out)) out->flags |= ESBA_FLAG_MULTISTABLE;
        return status;
    }
    if (!have_best) {
        best_p = start.pressure;
        copy(w->best, w->lo, N);
    }
    w->p[IDX_P] = best_p;
    status = finish(w, a, &start, w->best, best_p, out);
    /* the nearest state that holds may lie past a snap too */
    if (have_best && status == ESBA_OK && !on_load_path(w, a, &start, best_p, out)) out->flags |= ESBA_FLAG_MULTISTABLE;
    return ESBA_UNREACHABLE;
}
