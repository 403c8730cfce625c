/* ------------------------------------------------------------------------------------------
 * The solver: esba's load history and continuation on the generated functions above, written
 * once as a template (esba/export/templates/solver.c) and filled in for this model.
 *
 * Every linear solve uses the Hessian's chain structure, H = diag(e) + C with
 * C[j][k] = c[max(j, k)] (esba/model/structured.py): an LDL^T elimination from the last segment
 * to the first costs O(n), and the signs of its pivots are those of H's eigenvalues (Sylvester),
 * so a positive smallest pivot means a stable state. Only the diagonal of H and its first row
 * are computed ({{NAME}}_cg_newton).
 * ------------------------------------------------------------------------------------------ */

#define REAL {{NAME}}_real
#define RC(x) ((REAL)(x))
#define N {{N}}
#define NP {{NP}}
#define SQRT {{SQRT}}
#define FABS {{FABS}}
#define WORK {{NAME}}_work

/* A pivot within this of zero, relative to the largest, is critical (esba.model.stability). */
#define CRITICAL_TOL RC({{CRITICAL_TOL}})
/* Newton has converged when its step is below this (rad): round-off of the gradient beyond it. */
#define STEP_TOL RC({{STEP_TOL}})
/* Newton that ends its iterations without a step below STEP_TOL has still converged when max
 * |dU/dtheta| is below this (N mm/rad; esba.solvers.newton's acceptance): near a cusp the Hessian is
 * nearly singular and amplifies the gradient's round-off into steps that never get that small, at
 * a state that is an equilibrium all the same. */
#define GRAD_TOL RC({{GRAD_TOL}})
/* Newton steps below this (rad) are round-off, amplified near a singular Hessian: their ratio says nothing. */
#define TINY RC({{TINY}})
/* Largest ratio of a step's second Newton correction to its first (Deuflhard's test that the
 * predictor was inside the corrector's region of convergence: esba.solvers.newton.CONTRACTION). */
#define CONTRACTION RC(0.25)
/* Bounds of every loop. */
#define MAX_NEWTON 12      /* corrector iterations of one step */
#define MAX_STEPS 400      /* steps of one ramp or walk, accepted or not */
#define MAX_MINIMISE 300   /* iterations of the minimiser that finds where a snap lands */
#define MAX_HALVINGS 60    /* halvings of a line search or a shift */
#define MAX_BISECT 60      /* bisections locating the end of a stable stretch */
/* Load steps: the largest (4 steps per ramp, as esba's fast path), the smallest before the
 * stable branch is declared ended (a fold: the Hessian turns singular there). */
#define H_MAX RC(0.25)
#define H_MIN RC({{H_MIN}})
/* Largest change of one segment angle in one step (rad): a longer step is halved. */
#define MAX_DTHETA RC(0.5)
/* A load step's predictor moves the state by at most MAX_PREDICT (rad, in sqrt(n) |dtheta|, about
 * the change of the total angle: the arclength measure and largest step of esba.paths), and the corrector may move
 * it from there by at most CORRECTOR_RATIO of that plus JUMP_FLOOR (round-off, amplified where the
 * Hessian nears singular): a corrector that goes further has left the branch (past a fold it
 * lands on another one), and the step is halved. */
#define MAX_PREDICT RC(0.25)
#define CORRECTOR_RATIO RC(0.5)
#define JUMP_FLOOR RC({{JUMP_FLOOR}})
/* Where the branch ends, a tangent below this (rad per unit load factor, in sqrt(n) |t|) means no
 * direction of motion: a symmetric branch point, not a fold (where the tangent grows without bound). */
#define BRANCH_POINT_TANGENT RC(1.0)
/* Where the landing state of a snap is sought: this far past the fold (load factor), after a
 * kick of SNAP_KICK / sqrt(n) rad along the critical mode (esba.paths.loading). */
#define SNAP_PAST RC({{SNAP_PAST}})
#define SNAP_KICK RC(0.05)
/* pressure_for_angle: largest step of the total angle (rad); the smallest before the walk stops
 * (the branch turns back in the angle); how close to its end (a fold, P = 0, the largest pressure)
 * the nearest reachable state is located, on the stable side (rad of total angle: at a fold the
 * Hessian's smallest eigenvalue is then still clearly positive). */
#define ANGLE_STEP RC(0.25)
#define ANGLE_TOL RC({{ANGLE_TOL}})
#define BISECT_TOL RC({{BISECT_TOL}})
/* Relative distance kept from the edge of the model's domain (esba.model.generated.DOMAIN_MARGIN). */
#define DOMAIN_MARGIN RC(1e-6)
#define PI RC(3.14159265358979323846)
/* The range in which the paper's model describes the actuator (esba.model.validity, read when this
 * file was exported): |strain| of the outer fibre or the chamber wall, |total bend| (rad), and the
 * pressure (MPa) and payload (N) beyond which the model is far outside the paper's experiments. */
#define STRAIN_LIMIT RC({{STRAIN_LIMIT}})
#define MAX_BEND RC({{MAX_BEND}})
#define PRESSURE_LIMIT RC({{PRESSURE_LIMIT}})
#define PAYLOAD_LIMIT RC({{PAYLOAD_LIMIT}})
/* pressure_for_angle: the load history at the pressure found reaches the same state when no angle
 * differs by more than this (rad; esba.analysis.stiffness.pressure_for_target's on_load_path). */
#define LOAD_PATH_TOL RC({{LOAD_PATH_TOL}})

static int all_finite(const REAL *x, int m) {
    int k;
    for (k = 0; k < m; ++k) {
        if (!isfinite(x[k])) return 0;
    }
    return 1;
}

/* The largest magnitude (not finite when an entry is not). */
static REAL max_abs(const REAL *x, int m) {
    REAL r = RC(0.0);
    int k;
    for (k = 0; k < m; ++k) {
        REAL v = FABS(x[k]);
        if (!isfinite(v)) return v;
        if (v > r) r = v;
    }
    return r;
}

static REAL sum(const REAL *x) {
    REAL s = RC(0.0);
    int k;
    for (k = 0; k < N; ++k) s += x[k];
    return s;
}

static REAL max_diff(const REAL *x, const REAL *y) {
    REAL r = RC(0.0);
    int k;
    for (k = 0; k < N; ++k) {
        REAL d = FABS(x[k] - y[k]);
        if (d > r) r = d;
    }
    return r;
}

static REAL distance(const REAL *x, const REAL *y) {
    REAL s = RC(0.0);
    int k;
    for (k = 0; k < N; ++k) s += (x[k] - y[k]) * (x[k] - y[k]);
    return SQRT(s);
}

static REAL norm2(const REAL *x) {
    REAL s = RC(0.0);
    int k;
    for (k = 0; k < N; ++k) s += x[k] * x[k];
    return SQRT(s);
}

static void copy(REAL *to, const REAL *from, int m) {
    int k;
    for (k = 0; k < m; ++k) to[k] = from[k];
}

/* ---------------------------------------------------------------- inputs */

static int check_params(const {{NAME}}_params *a) {
    if (a == NULL) return ESBA_BAD_INPUT;
    if (!isfinite(a->L) || !isfinite(a->r1) || !isfinite(a->r2) || !isfinite(a->d) || !isfinite(a->rho) || !isfinite(a->E) || !isfinite(a->M))
        return ESBA_BAD_PARAMETERS;
    if (!(a->L > 0) || !(a->r1 > 0) || !(a->r2 > 0) || !(a->E > 0) || !(a->d >= 0) || !(a->M >= 0)) return ESBA_BAD_PARAMETERS;
    if (!(a->r2 + a->d < a->r1) || !(a->rho >= 0) || !(a->rho < PI / 2)) return ESBA_BAD_PARAMETERS;
    return ESBA_OK;
}

static int check_loads(const {{NAME}}_loads *l) {
    if (l == NULL) return ESBA_BAD_INPUT;
    if (!isfinite(l->pressure) || !(l->pressure >= 0)) return ESBA_BAD_INPUT;
{{CHECK_LOADS}}    return ESBA_OK;
}

/* The model's parameter vector at the loads: the pressure times pf, the payloads' forces and the
 * weight times lf (the load factor), in the order of the generated functions: {{PARAM_NAMES}}. */
static void pack(const {{NAME}}_params *a, const {{NAME}}_loads *l, REAL pf, REAL lf, REAL *p) {
{{PACK}}}

/* The lowest segment angle of the domain (esba.model.generated.domain_lower_bound): the square
 * root of Eq. (10) needs L r2^2 + n r1^3 theta_i >= 0, its denominator L + n (r1 + d) theta_i > 0. */
static REAL lower_bound(const {{NAME}}_params *a) {
    REAL b1 = -a->L * a->r2 * a->r2 / (RC(N) * a->r1 * a->r1 * a->r1);
    REAL b2 = -a->L / (RC(N) * (a->r1 + a->d));
    return (b1 > b2 ? b1 : b2) * (RC(1.0) - DOMAIN_MARGIN);
}

static int inside(const WORK *w, const REAL *theta) {
    int k;
    for (k = 0; k < N; ++k) {
        if (!(theta[k] > w->lb)) return 0;
    }
    return 1;
}

/* Within 1e-6 (relative) of the domain's edge: a state that stops there met the edge, not an equilibrium. */
static int near_bound(const WORK *w, const REAL *theta) {
    int k;
    for (k = 0; k < N; ++k) {
        if (theta[k] - w->lb <= RC(1e-6) * (FABS(w->lb) > 1 ? FABS(w->lb) : RC(1.0))) return 1;
    }
    return 0;
}

/* The largest fraction (<= 1) of the step theta - x that keeps every angle inside the domain,
 * going at most halfway to its edge. */
static REAL fraction_inside(const WORK *w, const REAL *theta, const REAL *x) {
    REAL f = RC(1.0);
    int k;
    for (k = 0; k < N; ++k) {
        if (theta[k] - x[k] <= w->lb && x[k] > 0) {
            REAL g = RC(0.5) * (theta[k] - w->lb) / x[k];
            if (g < f) f = g;
        }
    }
    return f;
}

/* ---------------------------------------------------------------- the generated functions */

/* g, the diagonal of H and its first row at (theta, p) into w->g, w->hd, w->h0; 0 if not finite. */
static int eval_newton(WORK *w, const REAL *theta, const REAL *p) {
    w->arg[0] = theta;
    w->arg[1] = p;
    w->res[0] = w->g;
    w->res[1] = w->hd;
    w->res[2] = w->h0;
    {{NAME}}_cg_newton(w->arg, w->res, w->iw, w->w, 0);
    return all_finite(w->g, N) && all_finite(w->hd, N) && all_finite(w->h0, N);
}

/* dg/dlambda = (d/dp dU/dtheta) . dp at (theta, p) into out. */
static int eval_tangent(WORK *w, const REAL *theta, const REAL *p, const REAL *dp, REAL *out) {
    w->arg[0] = theta;
    w->arg[1] = p;
    w->arg[2] = dp;
    w->res[0] = out;
    {{NAME}}_cg_tangent(w->arg, w->res, w->iw, w->w, 0);
    return all_finite(out, N);
}

static REAL eval_energy(WORK *w, const REAL *theta, const REAL *p, REAL *terms) {
    REAL u = RC(0.0);
    w->arg[0] = theta;
    w->arg[1] = p;
    w->res[0] = &u;
    w->res[1] = terms;
    {{NAME}}_cg_energy(w->arg, w->res, w->iw, w->w, 0);
    return u;
}

/* The tip into w->tip and d(tip x, y)/dtheta into w->jac (column-major, 2 x n); points if not NULL. */
static void eval_kinematics(WORK *w, const REAL *theta, REAL length, REAL *points) {
    w->arg[0] = theta;
    w->arg[1] = &length;
    w->res[0] = w->tip;
    w->res[1] = points;
    w->res[2] = w->jac;
    {{NAME}}_cg_kinematics(w->arg, w->res, w->iw, w->w, 0);
}

/* ---------------------------------------------------------------- O(n) linear algebra */

/* The pivots of H + mu I into w->piv and the couplings into w->cpl, eliminating from the last
 * unknown to the first (esba.model.structured): p[k] = H[k][k] + mu - S[k], a[k] = c[k] - S[k],
 * S[k-1] = S[k] + a[k]^2 / p[k]. w->rel: the smallest pivot over the largest magnitude.
 * Returns 0 when a pivot is zero or not finite (H + mu I singular). */
static int factor(WORK *w, REAL mu) {
    REAL shift = RC(0.0), low, high = RC(0.0);
    int k;
    for (k = N - 1; k >= 0; --k) {
        REAL c = k > 0 ? w->h0[k] : RC(0.0);
        w->cpl[k] = c - shift;
        w->piv[k] = w->hd[k] + mu - shift;
        if (!isfinite(w->piv[k]) || w->piv[k] == 0) return 0;
        shift += w->cpl[k] * w->cpl[k] / w->piv[k];
    }
    low = w->piv[0];
    for (k = 0; k < N; ++k) {
        if (w->piv[k] < low) low = w->piv[k];
        if (FABS(w->piv[k]) > high) high = FABS(w->piv[k]);
    }
    w->rel = low / high;
    return isfinite(w->rel);
}

/* x = (H + mu I)^-1 b after factor() (x may be b). */
static void solve(WORK *w, const REAL *b, REAL *x) {
    REAL shift = RC(0.0), total = RC(0.0);
    int k;
    for (k = N - 1; k >= 0; --k) {
        w->beta[k] = b[k] - shift;
        shift += w->cpl[k] * w->beta[k] / w->piv[k];
    }
    for (k = 0; k < N; ++k) {
        x[k] = (w->beta[k] - w->cpl[k] * total) / w->piv[k];
        total += x[k];
    }
}

/* ---------------------------------------------------------------- Newton and the minimiser */

/* Newton on dU/dtheta = 0 at p from theta (in place), every step kept inside the domain.
 * Returns 1 when it converged. *contraction: its second step over its first; *low: the smallest
 * relative pivot of the Hessians it met. */
static int newton(WORK *w, REAL *theta, const REAL *p, int max_iter, REAL *contraction, REAL *low) {
    REAL first = RC(0.0), previous = RC(0.0);
    int it;
    *contraction = RC(0.0);
    *low = RC(1.0);
    for (it = 0; it < max_iter; ++it) {
        REAL size, f;
        int k;
        if (!eval_newton(w, theta, p) || !factor(w, RC(0.0))) return 0;
        if (w->rel < *low) *low = w->rel;
        solve(w, w->g, w->x);
        size = max_abs(w->x, N);
        if (!isfinite(size)) return 0;
        if (it == 0) first = size;
        if (it == 1 && first > TINY) *contraction = size / first;
        f = fraction_inside(w, theta, w->x);
        for (k = 0; k < N; ++k) theta[k] -= f * w->x[k];
        w->iterations++;
        if (f == RC(1.0) && size <= STEP_TOL) return 1;
        /* stalled at round-off: the steps no longer shrink and are already tiny */
        if (it > 0 && f == RC(1.0) && size <= RC(1e3) * STEP_TOL && size > RC(0.5) * previous) return 1;
        previous = size;
    }
    /* the steps never fell below STEP_TOL: round-off amplified by a nearly singular Hessian (near a
     * cusp) at a state that is an equilibrium all the same when its gradient is below GRAD_TOL */
    if (!eval_newton(w, theta, p) || !factor(w, RC(0.0))) return 0;
    if (w->rel < *low) *low = w->rel;
    return max_abs(w->g, N) <= GRAD_TOL;
}

/* A stable state near theta at p (in place): a Newton method whose Hessian is shifted (H + mu I)
 * until it is positive definite, with a backtracking line search on U kept inside the domain.
 * Returns 1 when it ends on a stable equilibrium. */
static int minimise(WORK *w, REAL *theta, const REAL *p) {
    int it;
    for (it = 0; it < MAX_MINIMISE; ++it) {
        REAL mu = RC(0.0), scale = RC(0.0), size, slope = RC(0.0), u0, alpha;
        int k, j;
        if (!eval_newton(w, theta, p)) return 0;
        for (k = 0; k < N; ++k) {
            if (FABS(w->hd[k]) > scale) scale = FABS(w->hd[k]);
        }
        for (j = 0; j <= MAX_HALVINGS; ++j) {
            if (factor(w, mu) && w->rel > CRITICAL_TOL) break;
            if (j == MAX_HALVINGS) return 0;
            mu = mu > 0 ? RC(4.0) * mu : RC(1e-4) * (scale > 0 ? scale : RC(1.0));
        }
        solve(w, w->g, w->x);
        size = max_abs(w->x, N);
        if (!isfinite(size)) return 0;
        if (mu == 0 && size < RC(1e-2)) {
            /* positive definite and close: Newton's own steps (quadratic convergence) */
            REAL contraction, low;
            if (!newton(w, theta, p, MAX_NEWTON, &contraction, &low)) return 0;
            if (!eval_newton(w, theta, p) || !factor(w, RC(0.0))) return 0;
            return w->rel > CRITICAL_TOL;
        }
        if (size > MAX_DTHETA) {
            for (k = 0; k < N; ++k) w->x[k] *= MAX_DTHETA / size;
        }
        for (k = 0; k < N; ++k) slope -= w->g[k] * w->x[k];
        u0 = eval_energy(w, theta, p, NULL);
        alpha = fraction_inside(w, theta, w->x);
        for (j = 0; j < MAX_HALVINGS; ++j) {
            REAL u1;
            for (k = 0; k < N; ++k) w->trial[k] = theta[k] - alpha * w->x[k];
            u1 = eval_energy(w, w->trial, p, NULL);
            if (isfinite(u1) && u1 <= u0 + RC(1e-4) * alpha * slope) break;
            alpha *= RC(0.5);
        }
        if (j == MAX_HALVINGS) return 0;
        copy(theta, w->trial, N);
        w->iterations++;
    }
    return 0;
}

/* ---------------------------------------------------------------- following the stable branch */

/* w->p = w->p0 + lam w->dp */
static void at_lambda(WORK *w, REAL lam) {
    int k;
    for (k = 0; k < NP; ++k) w->p[k] = w->p0[k] + lam * w->dp[k];
}

/* The tangent dtheta/dlambda = -H^-1 dg/dlambda at (theta, w->p) into w->t. */
static int tangent(WORK *w, const REAL *theta) {
    int k;
    if (!eval_tangent(w, theta, w->p, w->dp, w->gl) || !eval_newton(w, theta, w->p) || !factor(w, RC(0.0))) return 0;
    solve(w, w->gl, w->t);
    for (k = 0; k < N; ++k) w->t[k] = -w->t[k];
    return all_finite(w->t, N);
}

/* The stable branch ended at (theta, *lam): the actuator snaps. The state it lands in is sought
 * just past the fold, from theta kicked along the critical mode (the direction it was moving in:
 * towards the unstable side, where the energy falls once the fold is passed) by the minimiser; a
 * kick it cannot start from is made four times larger, twice. At a symmetric branch point (no
 * direction of motion) both sides are tried and the nearer landing state is taken: when it is no
 * farther than the first kick, a stable branch goes on from the branch point (a straight actuator
 * buckling) and there was no jump. Past a fold any landing state is a jump, however small (near a
 * cusp). Returns 1 with theta, *lam moved past the fold. */
static int snap(WORK *w, REAL *theta, REAL *lam, int ramp_id, {{NAME}}_result *out) {
    REAL past = *lam + SNAP_PAST > 1 ? RC(1.0) : *lam + SNAP_PAST;
    REAL norm, eps0 = SNAP_KICK / SQRT(RC(N)), best_d = RC(-1.0);
    int k, s, signs = 1, tries;
    at_lambda(w, *lam);
    if (!tangent(w, theta)) return 0;
    norm = SQRT(RC(N)) * norm2(w->t);
    if (!(norm > BRANCH_POINT_TANGENT)) {
        /* no direction of motion: a branch point; start the inverse iteration from a ramp */
        for (k = 0; k < N; ++k) w->t[k] = RC(1.0) + RC(k) / RC(N);
        signs = 2;
    }
    copy(w->v, w->t, N);
    for (tries = 0; tries < 3; ++tries) { /* inverse iteration: the mode of the smallest eigenvalue */
        solve(w, w->v, w->v);
        norm = RC(0.0);
        for (k = 0; k < N; ++k) norm += w->v[k] * w->v[k];
        norm = SQRT(norm);
        if (!(norm > 0) || !isfinite(norm)) return 0;
        for (k = 0; k < N; ++k) w->v[k] /= norm;
    }
    copy(w->keep, theta, N);
    at_lambda(w, past);
    for (s = 0; s < signs; ++s) {
        REAL eps = eps0, sign = s == 0 ? RC(1.0) : RC(-1.0);
        for (tries = 0; tries < 3; ++tries, eps *= RC(4.0)) {
            for (k = 0; k < N; ++k) w->y[k] = theta[k] + sign * eps * w->v[k];
            for (k = 0; k < N; ++k) {
                if (w->y[k] <= w->lb) w->y[k] = RC(0.5) * (theta[k] + w->lb);
            }
            if (minimise(w, w->y, w->p)) {
                REAL d = distance(w->y, theta);
                if (best_d < 0 || d < best_d) {
                    best_d = d;
                    copy(w->best, w->y, N);
                }
                break;
            }
        }
    }
    if (best_d < 0) return 0;
    copy(theta, w->best, N);
    *lam = past;
    if (signs == 2 && best_d <= eps0) return 1; /* no jump: a branch point where a stable branch goes on (buckling) */
    if (out->snaps == 0) {
        out->snap_ramp = ramp_id;
        out->snap_at = *lam;
        out->snap_from = sum(w->keep);
        out->snap_to = sum(w->best);
    }
    out->snaps++;
    return 1;
}

/* Settle theta at w->p on an equilibrium: Newton, and when that fails or ends on a state that is
 * not stable, the minimiser (the state falls to the nearest stable one). Returns a status. */
static int settle(WORK *w, REAL *theta) {
    REAL contraction, low;
    copy(w->keep, theta, N);
    if (newton(w, theta, w->p, MAX_NEWTON, &contraction, &low) && eval_newton(w, theta, w->p) && factor(w, RC(0.0)) && w->rel > CRITICAL_TOL)
        return ESBA_OK;
    copy(theta, w->keep, N);
    if (minimise(w, theta, w->p)) return ESBA_OK;
    copy(theta, w->keep, N);
    return near_bound(w, theta) ? ESBA_OUT_OF_DOMAIN : ESBA_NOT_CONVERGED;
}

/* Ramp lambda from 0 to 1 (p = w->p0 + lambda w->dp) from theta, following the stable branch by
 * natural-parameter continuation (tangent predictor, Newton corrector, accepted only with every
 * Hessian met positive definite, a contracting corrector and a bounded change); a step that fails
 * is halved, and when it falls below H_MIN the stable branch has ended: at the domain's edge
 * (ESBA_OUT_OF_DOMAIN) or at a fold, where it snaps. theta: in, the start; out, the state reached. */
static int ramp(WORK *w, REAL *theta, int ramp_id, {{NAME}}_result *out) {
    REAL lam = RC(0.0), h = H_MAX;
    int step, status;
    at_lambda(w, RC(0.0));
    status = settle(w, theta);
    if (status != ESBA_OK) return status;
    if (max_abs(w->dp, NP) == 0) return ESBA_OK;
    for (step = 0; step < MAX_STEPS && lam < 1; ++step) {
        REAL target = lam + h < 1 ? lam + h : RC(1.0), contraction, low, predicted;
        int k, accepted;
        at_lambda(w, lam);
        if (!tangent(w, theta)) return ESBA_NOT_CONVERGED;
        predicted = (target - lam) * SQRT(RC(N)) * norm2(w->t);
        if (predicted > MAX_PREDICT) { /* a shorter step: the predictor moves the angles by at most MAX_PREDICT */
            target = lam + (target - lam) * MAX_PREDICT / predicted;
            predicted = MAX_PREDICT;
            h = target - lam;
        }
        for (k = 0; k < N; ++k) {
            w->trial[k] = theta[k] + (target - lam) * w->t[k];
            if (w->trial[k] <= w->lb) w->trial[k] = RC(0.5) * (theta[k] + w->lb);
        }
        copy(w->y, w->trial, N);
        at_lambda(w, target);
        accepted = newton(w, w->trial, w->p, MAX_NEWTON, &contraction, &low) && low > CRITICAL_TOL && contraction <= CONTRACTION &&
                   SQRT(RC(N)) * distance(w->trial, w->y) <= CORRECTOR_RATIO * predicted + JUMP_FLOOR && max_diff(w->trial, theta) <= MAX_DTHETA;
        if (accepted && eval_newton(w, w->trial, w->p) && factor(w, RC(0.0)) && w->rel > CRITICAL_TOL) {
            copy(theta, w->trial, N);
            lam = target;
            out->steps++;
            if (contraction < RC(0.1)) h = RC(2.0) * h < H_MAX ? RC(2.0) * h : H_MAX;
            continue;
        }
        h *= RC(0.5);
        if (h >= H_MIN) continue;
        /* the stable branch ends at lam */
        if (near_bound(w, theta)) return ESBA_OUT_OF_DOMAIN;
        if (!snap(w, theta, &lam, ramp_id, out)) return ESBA_NOT_CONVERGED;
        h = H_MAX;
    }
    return lam < 1 ? ESBA_NOT_CONVERGED : ESBA_OK;
}

/* ---------------------------------------------------------------- results */

static void zero_result({{NAME}}_result *out) {
    int k;
    for (k = 0; k < N; ++k) out->theta[k] = RC(0.0);
    out->total_angle = out->pressure = out->energy = out->gradient_norm = out->min_pivot = RC(0.0);
    out->tip[0] = out->tip[1] = out->tip[2] = RC(0.0);
    out->iterations = out->steps = out->snaps = 0;
    out->snap_ramp = -1;
    out->snap_at = out->snap_from = out->snap_to = RC(0.0);
    out->flags = 0;
}

/* Where theta (with the tip's x, the pressure and the loads' payloads) lies outside the model's
 * range: the ESBA_FLAG_* bits, by the rules of esba.model.validity.assess. */
static int range_flags(const {{NAME}}_params *a, const {{NAME}}_loads *l, const REAL *theta, REAL tip_x, REAL pressure) {
    int k, flags = 0;
    for (k = 0; k < N; ++k) {
        /* the outer fibre, 2 r1 from the inextensible layer (Eq. 6), over the segment length L / n */
        REAL axial = RC(2.0) * a->r1 * RC(N) * theta[k] / a->L;
        /* the chamber wall: Delta r2 / (r1 - r2), the radius from Eq. (10) (0 where the chamber is closed) */
        REAL num = a->L * a->r2 * a->r2 + RC(N) * a->r1 * a->r1 * a->r1 * theta[k];
        REAL den = a->L + RC(N) * (a->d + a->r1) * theta[k];
        REAL radius = den > 0 ? SQRT((num > 0 ? num : RC(0.0)) / den) : RC(0.0);
        if (FABS(axial) > STRAIN_LIMIT) flags |= ESBA_FLAG_AXIAL_STRAIN;
        if (FABS((radius - a->r2) / (a->r1 - a->r2)) > STRAIN_LIMIT) flags |= ESBA_FLAG_RADIAL_STRAIN;
    }
    if (FABS(sum(theta)) > MAX_BEND) flags |= ESBA_FLAG_TOTAL_BEND;
    if (tip_x < 0) flags |= ESBA_FLAG_TIP_BEHIND_BASE;
    if (pressure > PRESSURE_LIMIT) flags |= ESBA_FLAG_PRESSURE_RANGE;
    (void)l;
{{PAYLOAD_FLAG}}    return flags;
}

/* Fill out from theta at w->p (the full loads); the status of a converged state: stable or not. */
static int finish(WORK *w, const {{NAME}}_params *a, const {{NAME}}_loads *l, const REAL *theta, REAL pressure, {{NAME}}_result *out) {
    int k, ok;
    for (k = 0; k < N; ++k) out->theta[k] = theta[k];
    out->total_angle = sum(theta);
    out->pressure = pressure;
    eval_kinematics(w, theta, a->L, NULL);
    out->tip[0] = w->tip[0];
    out->tip[1] = w->tip[1];
    out->tip[2] = w->tip[2];
    out->energy = eval_energy(w, theta, w->p, NULL);
    ok = eval_newton(w, theta, w->p) && factor(w, RC(0.0));
    out->gradient_norm = ok ? max_abs(w->g, N) : RC(0.0);
    out->min_pivot = ok ? w->rel : RC(0.0);
    out->iterations = w->iterations;
    if (!all_finite(out->tip, 3) || !isfinite(out->energy)) {
        out->tip[0] = out->tip[1] = out->tip[2] = out->energy = RC(0.0);
        return ESBA_OUT_OF_DOMAIN;
    }
    out->flags = range_flags(a, l, theta, out->tip[0], pressure);
    return ok && w->rel > CRITICAL_TOL ? ESBA_OK : ESBA_UNSTABLE;
}

static int begin(int n, const {{NAME}}_params *a, const {{NAME}}_loads *l, {{NAME}}_result *out, WORK *w) {
    int status;
    if (out == NULL || w == NULL) return ESBA_BAD_INPUT;
    zero_result(out);
    if (n != N) return ESBA_BAD_SIZE;
    status = check_params(a);
    if (status != ESBA_OK) return status;
    status = check_loads(l);
    if (status != ESBA_OK) return status;
    w->lb = lower_bound(a);
    w->iterations = 0;
    return ESBA_OK;
}

/* ---------------------------------------------------------------- the API */

void {{NAME}}_default_params({{NAME}}_params *a) {
    if (a == NULL) return;
    a->L = RC(135.0);
    a->r1 = RC(8.0);
    a->r2 = RC(3.0);
    a->d = RC(4.0);
    a->rho = RC(10.0) * PI / RC(180.0);
    a->E = RC(0.54);
    a->M = RC(0.035);
}

void {{NAME}}_default_loads({{NAME}}_loads *l) {
    if (l == NULL) return;
    l->pressure = RC(0.0);
{{DEFAULT_LOADS}}}

/* A state to start from: NULL, or finite, inside the domain, at loads that are allowed. */
static int check_from(const WORK *w, const {{NAME}}_state *from) {
    int status;
    if (from == NULL) return ESBA_OK;
    status = check_loads(&from->loads);
    if (status != ESBA_OK) return status;
    if (!all_finite(from->theta, N)) return ESBA_BAD_INPUT;
    return inside(w, from->theta) ? ESBA_OK : ESBA_OUT_OF_DOMAIN;
}

/* The load history to l, leaving the state reached in w->lo: from the straight state (from ==
 * NULL) the pressure unloaded, then the payloads and weight; else every load from from->loads. */
static int history(WORK *w, const {{NAME}}_params *a, const {{NAME}}_loads *l, const {{NAME}}_state *from, {{NAME}}_result *out) {
    int k, status;
    if (from != NULL) {
        copy(w->lo, from->theta, N);
        pack(a, &from->loads, RC(1.0), RC(1.0), w->p0);
        pack(a, l, RC(1.0), RC(1.0), w->dp);
        for (k = 0; k < NP; ++k) w->dp[k] -= w->p0[k];
        return ramp(w, w->lo, 2, out);
    }
    for (k = 0; k < N; ++k) w->lo[k] = RC(0.0);
    /* the pressure, unloaded, from the straight state */
    pack(a, l, RC(0.0), RC(0.0), w->p0);
    pack(a, l, RC(1.0), RC(0.0), w->dp);
    for (k = 0; k < NP; ++k) w->dp[k] -= w->p0[k];
    status = ramp(w, w->lo, 0, out);
    if (status != ESBA_OK) return status;
    /* then the payloads and the weight together */
    pack(a, l, RC(1.0), RC(0.0), w->p0);
    pack(a, l, RC(1.0), RC(1.0), w->dp);
    for (k = 0; k < NP; ++k) w->dp[k] -= w->p0[k];
    return ramp(w, w->lo, 1, out);
}

int {{NAME}}_equilibrium(int n, const {{NAME}}_params *a, const {{NAME}}_loads *l, const {{NAME}}_state *from, {{NAME}}_result *out, WORK *w) {
    int status = begin(n, a, l, out, w), verdict;
    if (status != ESBA_OK) return status;
    status = check_from(w, from);
    if (status != ESBA_OK) return status;
    status = history(w, a, l, from, out);
    pack(a, l, RC(1.0), RC(1.0), w->p);
    verdict = finish(w, a, l, w->lo, l->pressure, out);
    if (status != ESBA_OK) return status;
    if (verdict != ESBA_OK) return verdict;
    return out->snaps > 0 ? ESBA_SNAPPED : ESBA_OK;
}

int {{NAME}}_newton(int n, const {{NAME}}_params *a, const {{NAME}}_loads *l, const REAL *theta0, {{NAME}}_result *out, WORK *w) {
    REAL contraction, low;
    int status = begin(n, a, l, out, w), converged;
    if (status != ESBA_OK) return status;
    if (theta0 == NULL || !all_finite(theta0, N)) return ESBA_BAD_INPUT;
    if (!inside(w, theta0)) return ESBA_OUT_OF_DOMAIN;
    copy(w->lo, theta0, N);
    pack(a, l, RC(1.0), RC(1.0), w->p);
    converged = newton(w, w->lo, w->p, 4 * MAX_NEWTON, &contraction, &low);
    if (!converged) {
        copy(w->lo, theta0, N);
        status = near_bound(w, w->lo) ? ESBA_OUT_OF_DOMAIN : ESBA_NOT_CONVERGED;
    }
    pack(a, l, RC(1.0), RC(1.0), w->p);
    converged = finish(w, a, l, w->lo, l->pressure, out);
    return status != ESBA_OK ? status : converged;
}

{{INVERSE}}

int {{NAME}}_stiffness(int n, const {{NAME}}_params *a, const {{NAME}}_loads *l, const REAL *theta, {{NAME}}_stiffness_result *out, WORK *w) {
    REAL c[2][2], det;
    int i, j, k, status;
    if (out == NULL || w == NULL) return ESBA_BAD_INPUT;
    for (i = 0; i < 2; ++i) {
        for (j = 0; j < 2; ++j) out->compliance[i][j] = out->stiffness[i][j] = RC(0.0);
    }
    out->horizontal = out->vertical = out->min_pivot = RC(0.0);
    if (n != N) return ESBA_BAD_SIZE;
    status = check_params(a);
    if (status != ESBA_OK) return status;
    status = check_loads(l);
    if (status != ESBA_OK) return status;
    if (theta == NULL || !all_finite(theta, N)) return ESBA_BAD_INPUT;
    w->lb = lower_bound(a);
    if (!inside(w, theta)) return ESBA_OUT_OF_DOMAIN;
    pack(a, l, RC(1.0), RC(1.0), w->p);
    if (!eval_newton(w, theta, w->p)) return ESBA_OUT_OF_DOMAIN;
    if (!factor(w, RC(0.0))) return ESBA_UNSTABLE;
    out->min_pivot = w->rel;
    eval_kinematics(w, theta, a->L, NULL);
    for (k = 0; k < N; ++k) {
        w->x[k] = w->jac[2 * k];
        w->y[k] = w->jac[2 * k + 1];
    }
    solve(w, w->x, w->t);
    solve(w, w->y, w->v);
    c[0][0] = c[0][1] = c[1][0] = c[1][1] = RC(0.0);
    for (k = 0; k < N; ++k) {
        c[0][0] += w->jac[2 * k] * w->t[k];
        c[0][1] += w->jac[2 * k] * w->v[k];
        c[1][0] += w->jac[2 * k + 1] * w->t[k];
        c[1][1] += w->jac[2 * k + 1] * w->v[k];
    }
    /* mm/N -> m/N, symmetric */
    out->compliance[0][0] = c[0][0] / RC(1000.0);
    out->compliance[1][1] = c[1][1] / RC(1000.0);
    out->compliance[0][1] = out->compliance[1][0] = RC(0.5) * (c[0][1] + c[1][0]) / RC(1000.0);
    if (!all_finite(&out->compliance[0][0], 4)) {
        out->compliance[0][0] = out->compliance[0][1] = out->compliance[1][0] = out->compliance[1][1] = RC(0.0);
        return ESBA_UNSTABLE;
    }
    if (out->compliance[1][1] != 0) out->horizontal = RC(1.0) / out->compliance[1][1];
    if (out->compliance[0][0] != 0) out->vertical = RC(1.0) / out->compliance[0][0];
    det = out->compliance[0][0] * out->compliance[1][1] - out->compliance[0][1] * out->compliance[1][0];
    if (FABS(det) > RC({{SINGULAR_TOL}}) * FABS(out->compliance[0][0] * out->compliance[1][1]) && det != 0) {
        out->stiffness[0][0] = out->compliance[1][1] / det;
        out->stiffness[1][1] = out->compliance[0][0] / det;
        out->stiffness[0][1] = out->stiffness[1][0] = -out->compliance[0][1] / det;
    }
    return w->rel > CRITICAL_TOL ? ESBA_OK : ESBA_UNSTABLE;
}

static int eval_begin(int n, const {{NAME}}_params *a, const {{NAME}}_loads *l, const REAL *theta, const REAL *result, WORK *w) {
    int status;
    if (w == NULL || result == NULL || theta == NULL) return ESBA_BAD_INPUT;
    if (n != N) return ESBA_BAD_SIZE;
    status = check_params(a);
    if (status != ESBA_OK) return status;
    if (l != NULL) {
        status = check_loads(l);
        if (status != ESBA_OK) return status;
    }
    if (!all_finite(theta, N)) return ESBA_BAD_INPUT;
    w->lb = lower_bound(a);
    if (!inside(w, theta)) return ESBA_OUT_OF_DOMAIN;
    return ESBA_OK;
}

int {{NAME}}_energy(int n, const {{NAME}}_params *a, const {{NAME}}_loads *l, const REAL *theta, REAL *energy, REAL *terms, WORK *w) {
    int status = eval_begin(n, a, l == NULL ? NULL : l, theta, energy, w);
    if (status != ESBA_OK) return status;
    if (l == NULL) return ESBA_BAD_INPUT;
    pack(a, l, RC(1.0), RC(1.0), w->p);
    *energy = eval_energy(w, theta, w->p, terms);
    return isfinite(*energy) ? ESBA_OK : ESBA_OUT_OF_DOMAIN;
}

int {{NAME}}_gradient(int n, const {{NAME}}_params *a, const {{NAME}}_loads *l, const REAL *theta, REAL *gradient, WORK *w) {
    int status = eval_begin(n, a, l, theta, gradient, w);
    if (status != ESBA_OK) return status;
    if (l == NULL) return ESBA_BAD_INPUT;
    pack(a, l, RC(1.0), RC(1.0), w->p);
    if (!eval_newton(w, theta, w->p)) return ESBA_OUT_OF_DOMAIN;
    copy(gradient, w->g, N);
    return ESBA_OK;
}

int {{NAME}}_hessian(int n, const {{NAME}}_params *a, const {{NAME}}_loads *l, const REAL *theta, REAL *hessian, WORK *w) {
    int status = eval_begin(n, a, l, theta, hessian, w), j, k;
    if (status != ESBA_OK) return status;
    if (l == NULL) return ESBA_BAD_INPUT;
    pack(a, l, RC(1.0), RC(1.0), w->p);
    if (!eval_newton(w, theta, w->p)) return ESBA_OUT_OF_DOMAIN;
    /* H[j][k] = c[max(j, k)] off the diagonal, c[k] = H[0][k] (esba.model.structured) */
    for (j = 0; j < N; ++j) {
        for (k = 0; k < N; ++k) hessian[j * N + k] = j == k ? w->hd[j] : w->h0[j > k ? j : k];
    }
    return ESBA_OK;
}

int {{NAME}}_tip(int n, const {{NAME}}_params *a, const REAL *theta, REAL *tip, REAL *points, WORK *w) {
    int status = eval_begin(n, a, NULL, theta, tip, w);
    if (status != ESBA_OK) return status;
    eval_kinematics(w, theta, a->L, points);
    tip[0] = w->tip[0];
    tip[1] = w->tip[1];
    tip[2] = w->tip[2];
    return all_finite(tip, 3) ? ESBA_OK : ESBA_OUT_OF_DOMAIN;
}

unsigned long {{NAME}}_work_bytes(void) { return (unsigned long)sizeof(WORK); }

const char *{{NAME}}_status_name(int status) {
    switch (status) {
    case ESBA_OK: return "ok";
    case ESBA_UNSTABLE: return "unstable";
    case ESBA_SNAPPED: return "snapped";
    case ESBA_UNREACHABLE: return "unreachable";
    case ESBA_NOT_CONVERGED: return "not_converged";
    case ESBA_OUT_OF_DOMAIN: return "out_of_domain";
    case ESBA_BAD_INPUT: return "bad_input";
    case ESBA_BAD_PARAMETERS: return "bad_parameters";
    case ESBA_BAD_SIZE: return "bad_size";
    default: return "unknown";
    }
}

const char *{{NAME}}_flag_name(int flag) {
    switch (flag) {
{{FLAG_CASES}}    default: return "unknown";
    }
}
