/* ------------------------------------------------------------------------------------------
 * The solver: esba's load history and continuation on the generated 3-D functions above, written
 * once as a template (esba/export/templates/solver3d.c) and filled in for this model.
 *
 * The Hessian of the 3-D model is dense (3n x 3n): every linear solve is an LDL^T elimination
 * without pivoting, O(n^3) with n small; the signs of its pivots are those of H's eigenvalues
 * (Sylvester), so a positive smallest pivot means a stable state.
 * ------------------------------------------------------------------------------------------ */

#define REAL {{NAME}}_real
#define RC(x) ((REAL)(x))
#define N {{N}}
#define NQ {{M}}
#define NP {{NP}}
#define SQRT {{SQRT}}
#define FABS {{FABS}}
#define WORK {{NAME}}_work

/* A pivot within this of zero, relative to the largest, is critical (esba.model.stability). */
#define CRITICAL_TOL RC({{CRITICAL_TOL}})
/* Newton has converged when its step, or the error its contraction says is left after the step,
 * is below this (rad): round-off of the gradient beyond it. */
#define STEP_TOL RC({{STEP_TOL}})
/* Newton that ends its iterations without a step below STEP_TOL has still converged when max
 * |dU/dq| is below this (N mm/rad; esba.solvers.newton's acceptance). */
#define GRAD_TOL RC({{GRAD_TOL}})
/* A state on the way (a load step before the last of a ramp) is converged to this (rad): only the
 * end of a ramp needs STEP_TOL. */
#define PATH_TOL (STEP_TOL > RC(1e-8) ? STEP_TOL : RC(1e-8))
/* Newton steps below this (rad) are round-off: their ratio says nothing. */
#define TINY RC({{TINY}})
/* Largest ratio of a step's second Newton correction to its first (Deuflhard's test that the
 * predictor was inside the corrector's region of convergence: esba.solvers.newton.CONTRACTION). */
#define CONTRACTION RC(0.25)
/* Bounds of every loop. */
#define MAX_NEWTON 12      /* corrector iterations of one step */
#define MAX_STEPS 400      /* steps of one ramp or walk, accepted or not */
#define MAX_MINIMISE 300   /* iterations of the minimiser that finds where a jump lands */
#define MAX_HALVINGS 60    /* halvings of a line search or a shift */
#define MAX_INVERSE 8      /* inverse iterations for the critical mode */
#define MAX_SADDLES 6      /* saddles the minimiser leaves along their softest mode */
/* How far the minimiser moves off a saddle it fell onto (rad, along the unit mode). */
#define SADDLE_KICK RC(1e-3)
/* Load steps: the largest (the whole ramp: MAX_PREDICT bounds a step by how far the state moves)
 * and the smallest before the stable branch is declared ended (a fold or a branch point: the
 * Hessian turns singular there). */
#define H_MAX RC(1.0)
#define H_MIN RC({{H_MIN}})
/* Largest change of one unknown in one step (rad): a longer step is halved. */
#define MAX_DQ RC(0.5)
/* A load step's predictor moves the state by at most MAX_PREDICT (rad, in sqrt(n) |dq|) and the
 * corrector may move it from there by at most CORRECTOR_RATIO of that plus JUMP_FLOOR: a corrector
 * that goes further has left the branch, and the step is halved. */
#define MAX_PREDICT RC(0.5)
/* The second-order term of a predictor is used when it is at most this share of the first-order one. */
#define QUADRATIC RC(0.5)
#define CORRECTOR_RATIO RC(0.5)
#define JUMP_FLOOR RC({{JUMP_FLOOR}})
/* Where the landing state of a jump is sought: this far past the end of the branch (load factor),
 * after a kick of SNAP_KICK / sqrt(n) rad along the critical mode. */
#define SNAP_PAST RC({{SNAP_PAST}})
#define SNAP_KICK RC(0.05)
/* A critical mode whose tangent share is below this is a branch point (no direction of motion
 * along it): both of its sides are tried. */
#define ALIGNED RC(0.1)
/* A critical mode with more than this share (squared norm) in psi and tau is sideways. */
#define SIDEWAYS RC(0.5)
/* pressure_for_angle: largest step of the total angle (rad) and the smallest before the walk
 * stops; a pressure step's derivative (rad per MPa) below this means the angle no longer moves. */
#define ANGLE_STEP RC(0.25)
#define ANGLE_TOL RC({{ANGLE_TOL}})
/* Relative distance kept from the edge of the model's domain (esba.model.generated.DOMAIN_MARGIN). */
#define DOMAIN_MARGIN RC(1e-6)
#define PI RC(3.14159265358979323846)
/* The range in which the paper's model describes the actuator (esba.model.validity). */
#define STRAIN_LIMIT RC({{STRAIN_LIMIT}})
#define MAX_BEND RC({{MAX_BEND}})
#define PRESSURE_LIMIT RC({{PRESSURE_LIMIT}})
#define PAYLOAD_LIMIT RC({{PAYLOAD_LIMIT}})
/* pressure_for_angle: the load history at the pressure found reaches the same state when no
 * unknown differs by more than this (rad). */
#define LOAD_PATH_TOL RC({{LOAD_PATH_TOL}})

static int all_finite(const REAL *x, int m) {
    int k;
    for (k = 0; k < m; ++k) {
        if (!isfinite(x[k])) return 0;
    }
    return 1;
}

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

static REAL sum_n(const REAL *x) {
    REAL s = RC(0.0);
    int k;
    for (k = 0; k < N; ++k) s += x[k];
    return s;
}

static REAL max_diff(const REAL *x, const REAL *y) {
    REAL r = RC(0.0);
    int k;
    for (k = 0; k < NQ; ++k) {
        REAL d = FABS(x[k] - y[k]);
        if (d > r) r = d;
    }
    return r;
}

static REAL distance(const REAL *x, const REAL *y) {
    REAL s = RC(0.0);
    int k;
    for (k = 0; k < NQ; ++k) s += (x[k] - y[k]) * (x[k] - y[k]);
    return SQRT(s);
}

static REAL norm2(const REAL *x) {
    REAL s = RC(0.0);
    int k;
    for (k = 0; k < NQ; ++k) s += x[k] * x[k];
    return SQRT(s);
}

static REAL dot(const REAL *x, const REAL *y) {
    REAL s = RC(0.0);
    int k;
    for (k = 0; k < NQ; ++k) s += x[k] * y[k];
    return s;
}

static void copy(REAL *to, const REAL *from, int m) {
    int k;
    for (k = 0; k < m; ++k) to[k] = from[k];
}

/* ---------------------------------------------------------------- inputs */

static int check_params(const {{NAME}}_params *a) {
    if (a == NULL) return ESBA_BAD_INPUT;
    if (!isfinite(a->L) || !isfinite(a->r1) || !isfinite(a->r2) || !isfinite(a->d) || !isfinite(a->rho) || !isfinite(a->E) || !isfinite(a->M) ||
        !isfinite(a->EI_side) || !isfinite(a->GJ))
        return ESBA_BAD_PARAMETERS;
    if (!(a->L > 0) || !(a->r1 > 0) || !(a->r2 > 0) || !(a->E > 0) || !(a->d >= 0) || !(a->M >= 0) || !(a->EI_side > 0) || !(a->GJ > 0))
        return ESBA_BAD_PARAMETERS;
    if (!(a->r2 + a->d < a->r1) || !(a->rho >= 0) || !(a->rho < PI / 2)) return ESBA_BAD_PARAMETERS;
    return ESBA_OK;
}

static int check_loads(const {{NAME}}_loads *l) {
    if (l == NULL) return ESBA_BAD_INPUT;
    if (!isfinite(l->pressure) || !(l->pressure >= 0)) return ESBA_BAD_INPUT;
{{CHECK_LOADS}}    return ESBA_OK;
}

/* The model's parameter vector: the pressure times pf, the payloads' forces, the moments and the
 * weight times lf (the load factor), in the order of the generated functions: {{PARAM_NAMES}}. */
static void pack(const {{NAME}}_params *a, const {{NAME}}_loads *l, REAL pf, REAL lf, REAL *p) {
{{PACK}}}

/* The lowest in-plane angle of the domain (esba.model.generated.domain_lower_bound). */
static REAL lower_bound(const {{NAME}}_params *a) {
{{LOWER_BOUND}}}

static int inside(const WORK *w, const REAL *q) {
    int k;
    for (k = 0; k < N; ++k) {
        if (!(q[k] > w->lb)) return 0;
    }
    return 1;
}

static int near_bound(const WORK *w, const REAL *q) {
    int k;
    for (k = 0; k < N; ++k) {
        if (q[k] - w->lb <= RC(1e-6) * (FABS(w->lb) > 1 ? FABS(w->lb) : RC(1.0))) return 1;
    }
    return 0;
}

/* The largest fraction (<= 1) of the step q - x that keeps every in-plane angle inside the domain,
 * going at most halfway to its edge. */
static REAL fraction_inside(const WORK *w, const REAL *q, const REAL *x) {
    REAL f = RC(1.0);
    int k;
    for (k = 0; k < N; ++k) {
        if (q[k] - x[k] <= w->lb && x[k] > 0) {
            REAL g = RC(0.5) * (q[k] - w->lb) / x[k];
            if (g < f) f = g;
        }
    }
    return f;
}

/* ---------------------------------------------------------------- the generated functions */

/* g and H at (q, p) into w->g, w->h; 0 if not finite. */
static int eval_newton(WORK *w, const REAL *q, const REAL *p) {
    w->arg[0] = q;
    w->arg[1] = p;
    w->res[0] = w->g;
    w->res[1] = w->h;
    {{NAME}}_cg_newton(w->arg, w->res, w->iw, w->w, 0);
    return all_finite(w->g, NQ) && all_finite(w->h, NQ * NQ);
}

/* dg/dlambda = (d/dp dU/dq) . dp at (q, p) into out. */
static int eval_tangent(WORK *w, const REAL *q, const REAL *p, const REAL *dp, REAL *out) {
    w->arg[0] = q;
    w->arg[1] = p;
    w->arg[2] = dp;
    w->res[0] = out;
    {{NAME}}_cg_tangent(w->arg, w->res, w->iw, w->w, 0);
    return all_finite(out, NQ);
}

static REAL eval_energy(WORK *w, const REAL *q, const REAL *p, REAL *terms) {
    REAL u = RC(0.0);
    w->arg[0] = q;
    w->arg[1] = p;
    w->res[0] = &u;
    w->res[1] = terms;
    {{NAME}}_cg_energy(w->arg, w->res, w->iw, w->w, 0);
    return u;
}

/* The tip into w->tip, its rotation into w->rot (row-major), the 6 x 3n Jacobian of the tip's
 * translation and rotation into w->jac (column-major); points if not NULL. */
static void eval_kinematics(WORK *w, const REAL *q, REAL length, REAL *points) {
    w->arg[0] = q;
    w->arg[1] = &length;
    w->res[0] = w->tip;
    w->res[1] = w->rot;
    w->res[2] = points;
    w->res[3] = w->jac;
    {{NAME}}_cg_kinematics(w->arg, w->res, w->iw, w->w, 0);
}

/* ---------------------------------------------------------------- dense LDL^T */

/* The LDL^T factors of H + mu I (w->h, row-major) into w->fac (L below the diagonal) and w->piv.
 * w->rel: the smallest pivot over the largest magnitude. 0 when a pivot is zero or not finite. */
static int factor(WORK *w, REAL mu) {
    REAL low, high = RC(0.0);
    int i, j, k;
    for (j = 0; j < NQ; ++j) {
        REAL d = w->h[j * NQ + j] + mu;
        for (k = 0; k < j; ++k) d -= w->fac[j * NQ + k] * w->fac[j * NQ + k] * w->piv[k];
        if (!isfinite(d) || d == 0) return 0;
        w->piv[j] = d;
        for (i = j + 1; i < NQ; ++i) {
            REAL s = w->h[i * NQ + j];
            for (k = 0; k < j; ++k) s -= w->fac[i * NQ + k] * w->fac[j * NQ + k] * w->piv[k];
            w->fac[i * NQ + j] = s / d;
        }
    }
    low = w->piv[0];
    for (k = 0; k < NQ; ++k) {
        if (w->piv[k] < low) low = w->piv[k];
        if (FABS(w->piv[k]) > high) high = FABS(w->piv[k]);
    }
    w->rel = low / high;
    return isfinite(w->rel);
}

/* x = (H + mu I)^-1 b after factor() (x may be b). */
static void solve(WORK *w, const REAL *b, REAL *x) {
    int i, k;
    for (i = 0; i < NQ; ++i) {
        REAL s = b[i];
        for (k = 0; k < i; ++k) s -= w->fac[i * NQ + k] * w->z[k];
        w->z[i] = s;
    }
    for (i = 0; i < NQ; ++i) w->z[i] /= w->piv[i];
    for (i = NQ - 1; i >= 0; --i) {
        REAL s = w->z[i];
        for (k = i + 1; k < NQ; ++k) s -= w->fac[k * NQ + i] * x[k];
        x[i] = s;
    }
}

/* ---------------------------------------------------------------- Newton and the minimiser */

/* Newton on dU/dq = 0 at p from q (in place), every step kept inside the domain. Returns 1 when it
 * converged (a step below STEP_TOL, or an error left below tol by its contraction). *contraction:
 * its second step over its first; *low: the smallest relative pivot met. On return w->fac holds the
 * factors of the Hessian at its last iterate. */
static int newton_to(WORK *w, REAL *q, const REAL *p, int max_iter, REAL tol, REAL *contraction, REAL *low) {
    REAL first = RC(0.0), previous = RC(0.0);
    int it;
    *contraction = RC(0.0);
    *low = RC(1.0);
    for (it = 0; it < max_iter; ++it) {
        REAL size, f;
        int k;
        if (!eval_newton(w, q, p) || !factor(w, RC(0.0))) return 0;
        if (w->rel < *low) *low = w->rel;
        solve(w, w->g, w->x);
        size = max_abs(w->x, NQ);
        if (!isfinite(size)) return 0;
        if (it == 0) first = size;
        if (it == 1 && first > TINY) *contraction = size / first;
        f = fraction_inside(w, q, w->x);
        for (k = 0; k < NQ; ++k) q[k] -= f * w->x[k];
        w->iterations++;
        if (f == RC(1.0) && size <= STEP_TOL) return 1;
        if (it > 0 && f == RC(1.0) && size <= RC(1e3) * STEP_TOL && size > RC(0.5) * previous) return 1;
        /* converging quadratically: the error left after this step is at most theta / (1 - theta)
         * times it (theta = this step over the last; Deuflhard), and that is below tol */
        if (it > 0 && f == RC(1.0) && size < RC(0.5) * previous && size * size <= (previous - size) * tol) return 1;
        previous = size;
    }
    if (!eval_newton(w, q, p) || !factor(w, RC(0.0))) return 0;
    if (w->rel < *low) *low = w->rel;
    return max_abs(w->g, NQ) <= GRAD_TOL;
}

static int newton(WORK *w, REAL *q, const REAL *p, int max_iter, REAL *contraction, REAL *low) {
    return newton_to(w, q, p, max_iter, STEP_TOL, contraction, low);
}

/* A stable state near q at p (in place): Newton with the Hessian shifted (H + mu I) until it is
 * positive definite, a backtracking line search on U kept inside the domain. 1 on a stable equilibrium. */
static int minimise(WORK *w, REAL *q, const REAL *p) {
    int it, saddles = 0;
    for (it = 0; it < MAX_MINIMISE; ++it) {
        REAL mu = RC(0.0), scale = RC(0.0), size, slope = RC(0.0), u0, alpha;
        int k, j;
        if (!eval_newton(w, q, p)) return 0;
        for (k = 0; k < NQ; ++k) {
            if (FABS(w->h[k * NQ + k]) > scale) scale = FABS(w->h[k * NQ + k]);
        }
        for (j = 0; j <= MAX_HALVINGS; ++j) {
            if (factor(w, mu) && w->rel > CRITICAL_TOL) break;
            if (j == MAX_HALVINGS) return 0;
            mu = mu > 0 ? RC(4.0) * mu : RC(1e-4) * (scale > 0 ? scale : RC(1.0));
        }
        solve(w, w->g, w->x);
        size = max_abs(w->x, NQ);
        if (!isfinite(size)) return 0;
        if (mu == 0 && size < RC(1e-2)) {
            REAL contraction, low, norm, big = RC(0.0);
            int r;
            copy(w->hold, q, NQ);
            if (!newton(w, q, p, MAX_NEWTON, &contraction, &low)) {
                /* Newton's steps did not settle (a flat valley, as just past a symmetric branch
                 * point where the energy is quartic): back to the damped step from here */
                copy(q, w->hold, NQ);
                if (!eval_newton(w, q, p)) return 0;
                mu = RC(1e-4) * (scale > 0 ? scale : RC(1.0));
                for (j = 0; j <= MAX_HALVINGS; ++j) {
                    if (factor(w, mu) && w->rel > CRITICAL_TOL) break;
                    if (j == MAX_HALVINGS) return 0;
                    mu *= RC(4.0);
                }
                solve(w, w->g, w->x);
                size = max_abs(w->x, NQ);
                if (!isfinite(size)) return 0;
                goto damped;
            }
            if (!eval_newton(w, q, p) || !factor(w, RC(0.0))) return 0;
            if (w->rel > CRITICAL_TOL) return 1;
            /* Newton ended on a saddle (past a symmetric branch point the state it started from may
             * fall back to it): leave it along its softest mode (inverse iteration, the largest
             * entry positive) by SADDLE_KICK and go on minimising, at most MAX_SADDLES times */
            if (++saddles > MAX_SADDLES) return 0;
            for (k = 0; k < NQ; ++k) w->gl[k] = RC(1.0) + RC(k) / RC(NQ);
            for (r = 0; r < MAX_INVERSE; ++r) {
                solve(w, w->gl, w->gl);
                norm = norm2(w->gl);
                if (!(norm > 0) || !isfinite(norm)) return 0;
                for (k = 0; k < NQ; ++k) w->gl[k] /= norm;
            }
            for (k = 0; k < NQ; ++k) {
                if (FABS(w->gl[k]) > FABS(big)) big = w->gl[k];
            }
            for (k = 0; k < NQ; ++k) q[k] += (big < 0 ? -SADDLE_KICK : SADDLE_KICK) * w->gl[k];
            continue;
        }
    damped:
        if (size > MAX_DQ) {
            for (k = 0; k < NQ; ++k) w->x[k] *= MAX_DQ / size;
        }
        for (k = 0; k < NQ; ++k) slope -= w->g[k] * w->x[k];
        u0 = eval_energy(w, q, p, NULL);
        alpha = fraction_inside(w, q, w->x);
        for (j = 0; j < MAX_HALVINGS; ++j) {
            REAL u;
            for (k = 0; k < NQ; ++k) w->trial[k] = q[k] - alpha * w->x[k];
            u = eval_energy(w, w->trial, p, NULL);
            if (isfinite(u) && u <= u0 + RC(1e-4) * alpha * slope) break;
            alpha *= RC(0.5);
        }
        if (j == MAX_HALVINGS) return 0;
        copy(q, w->trial, NQ);
        w->iterations++;
    }
    return 0;
}

/* ---------------------------------------------------------------- following the stable branch */

static void at_lambda(WORK *w, REAL lam) {
    int k;
    for (k = 0; k < NP; ++k) w->p[k] = w->p0[k] + lam * w->dp[k];
}

/* The tangent dq/dlambda = -H^-1 dg/dlambda at (q, w->p) into w->t; factored: w->fac already
 * holds the LDL^T factors of the Hessian at (q, w->p), or at the corrector's last iterate that
 * reached q (ramp()). */
static int tangent_at(WORK *w, const REAL *q, int factored) {
    int k;
    if (!eval_tangent(w, q, w->p, w->dp, w->gl)) return 0;
    if (!factored && (!eval_newton(w, q, w->p) || !factor(w, RC(0.0)))) return 0;
    solve(w, w->gl, w->t);
    for (k = 0; k < NQ; ++k) w->t[k] = -w->t[k];
    return all_finite(w->t, NQ);
}

static int tangent(WORK *w, const REAL *q) { return tangent_at(w, q, 0); }

/* The share of v's squared norm out of the plane (psi and tau). */
static REAL side_share(const REAL *v) {
    REAL s = RC(0.0), all = RC(0.0);
    int k;
    for (k = 0; k < NQ; ++k) {
        all += v[k] * v[k];
        if (k >= N) s += v[k] * v[k];
    }
    return all > 0 ? s / all : RC(0.0);
}

/* The stable branch ended at (q, *lam): the actuator jumps. The critical mode (inverse iteration on
 * the Hessian, started from the tangent plus a fixed vector, so that a mode the tangent has no share
 * in, a sideways one under loads in the plane, is found too) gives the kick; when the tangent has a
 * share in it, the kick goes along the tangent (towards where the energy falls past a fold), else
 * (a branch point) both signs are tried, the mode's largest entry positive first, and the nearer
 * landing state is taken (a tie keeps the first). A landing state no farther than the first kick
 * from a branch point means a stable branch goes on there and there was no jump (out->snaps not
 * counted); a sideways critical mode is counted in out->sideways either way (the actuator left its
 * plane: lateral-torsional buckling). Returns 1 with q, *lam moved past the end. */
static int snap(WORK *w, REAL *q, REAL *lam, int ramp_id, {{NAME}}_result *out) {
    REAL past = *lam + SNAP_PAST > 1 ? RC(1.0) : *lam + SNAP_PAST;
    REAL norm, tnorm, eps0 = SNAP_KICK / SQRT(RC(N)), best_d = RC(-1.0), big = RC(0.0), share;
    int k, s, signs = 1, tries, jumped;
    at_lambda(w, *lam);
    if (!tangent(w, q)) return 0;
    tnorm = norm2(w->t);
    for (k = 0; k < NQ; ++k) w->v[k] = w->t[k] / (tnorm > 0 ? tnorm : RC(1.0)) + RC(0.1) * (RC(1.0) + RC(k) / RC(NQ));
    for (tries = 0; tries < MAX_INVERSE; ++tries) {
        solve(w, w->v, w->v);
        norm = norm2(w->v);
        if (!(norm > 0) || !isfinite(norm)) return 0;
        for (k = 0; k < NQ; ++k) w->v[k] /= norm;
    }
    if (tnorm > 0 && FABS(dot(w->v, w->t)) > ALIGNED * tnorm) {
        if (dot(w->v, w->t) < 0) {
            for (k = 0; k < NQ; ++k) w->v[k] = -w->v[k];
        }
    } else {
        signs = 2;
        for (k = 0; k < NQ; ++k) {
            if (FABS(w->v[k]) > FABS(big)) big = w->v[k];
        }
        if (big < 0) {
            for (k = 0; k < NQ; ++k) w->v[k] = -w->v[k];
        }
    }
    share = side_share(w->v);
    copy(w->keep, q, NQ);
    at_lambda(w, past);
    for (s = 0; s < signs; ++s) {
        REAL eps = eps0, sign = s == 0 ? RC(1.0) : RC(-1.0);
        for (tries = 0; tries < 3; ++tries, eps *= RC(4.0)) {
            for (k = 0; k < NQ; ++k) w->y[k] = q[k] + sign * eps * w->v[k];
            for (k = 0; k < N; ++k) {
                if (w->y[k] <= w->lb) w->y[k] = RC(0.5) * (q[k] + w->lb);
            }
            if (minimise(w, w->y, w->p)) {
                REAL d = distance(w->y, q);
                if (best_d < 0 || d < best_d) {
                    best_d = d;
                    copy(w->best, w->y, NQ);
                }
                break;
            }
        }
    }
    if (best_d < 0) return 0;
    copy(q, w->best, NQ);
    *lam = past;
    jumped = !(signs == 2 && best_d <= eps0);
    if (!jumped && !(share > SIDEWAYS)) return 1; /* a branch point in the plane where a stable branch goes on (buckling in the plane) */
    if (out->snaps + out->sideways == 0) {
        out->snap_ramp = ramp_id;
        out->snap_at = past;
        out->snap_from = sum_n(w->keep);
        out->snap_to = sum_n(w->best);
        out->snap_side = share;
    }
    if (jumped) out->snaps++;
    if (share > SIDEWAYS) out->sideways++;
    return 1;
}

/* Settle q at w->p on an equilibrium: Newton, else the minimiser. Returns a status. */
static int settle(WORK *w, REAL *q) {
    REAL contraction, low;
    copy(w->hold, q, NQ);
    /* Newton's last Hessian (one converged step from q) stands for q's: w->fac holds its factors */
    if (newton(w, q, w->p, MAX_NEWTON, &contraction, &low) && w->rel > CRITICAL_TOL) return ESBA_OK;
    copy(q, w->hold, NQ);
    if (minimise(w, q, w->p)) return ESBA_OK;
    copy(q, w->hold, NQ);
    return near_bound(w, q) ? ESBA_OUT_OF_DOMAIN : ESBA_NOT_CONVERGED;
}

/* Ramp lambda from 0 to 1 (p = w->p0 + lambda w->dp) from q, following the stable branch by
 * natural-parameter continuation (tangent predictor, with a second-order term from the last step's
 * tangent when that is small; Newton corrector, to PATH_TOL on the way and STEP_TOL at the end of
 * the ramp; a step accepted only with every
 * Hessian met positive definite, a contracting corrector and a bounded change); a step that fails
 * is halved, and when it falls below H_MIN the stable branch has ended: at the domain's edge
 * (ESBA_OUT_OF_DOMAIN) or where it jumps (snap()). q: in, the start; out, the state reached. */
static int ramp(WORK *w, REAL *q, int ramp_id, {{NAME}}_result *out) {
    REAL lam = RC(0.0), h = H_MAX;
    /* have: w->t is the tangent at (q, lam) (a halved step tries again from there). factored:
     * w->fac holds the factors of the Hessian at lam, at q (settle()) or at the corrector's last
     * iterate (an accepted step: one Newton step away from q, small enough for newton() to stop),
     * which the tangent uses instead of evaluating the Hessian once more */
    int step, status, have = 0, factored = 0, previous = 0;
    REAL lam_tp = RC(0.0);
    at_lambda(w, RC(0.0));
    status = settle(w, q);
    if (status != ESBA_OK) return status;
    factored = 1; /* settle() ends on the factors of the Hessian at the state it settled, or one converged Newton step from it */
    if (max_abs(w->dp, NP) == 0) return ESBA_OK;
    for (step = 0; step < MAX_STEPS && lam < 1; ++step) {
        REAL target = lam + h < 1 ? lam + h : RC(1.0), contraction, low, predicted;
        int k, accepted;
        at_lambda(w, lam);
        if (!have && !tangent_at(w, q, factored)) return ESBA_NOT_CONVERGED;
        have = 1;
        factored = 0;
        predicted = (target - lam) * SQRT(RC(N)) * norm2(w->t);
        if (predicted > MAX_PREDICT) {
            target = lam + (target - lam) * MAX_PREDICT / predicted;
            predicted = MAX_PREDICT;
            h = target - lam;
        }
        for (k = 0; k < NQ; ++k) w->trial[k] = q[k] + (target - lam) * w->t[k];
        for (k = 0; k < N; ++k) {
            if (w->trial[k] <= w->lb) w->trial[k] = RC(0.5) * (q[k] + w->lb);
        }
        copy(w->y, w->trial, NQ);
        if (previous) {
            /* the corrector starts from the second-order predictor: the tangent's change since the
             * last accepted step gives d2q/dlambda2; used only when its term is at most
             * QUADRATIC of the tangent's (else the Euler predictor), and the corrector's distance
             * is still measured from the Euler predictor w->y */
            REAL d = target - lam, lin = RC(0.0), quad = RC(0.0);
            for (k = 0; k < NQ; ++k) {
                REAL a = RC(0.5) * d * d * (w->t[k] - w->tp[k]) / (lam - lam_tp);
                if (FABS(a) > quad) quad = FABS(a);
                if (FABS(d * w->t[k]) > lin) lin = FABS(d * w->t[k]);
            }
            if (isfinite(quad) && quad <= QUADRATIC * lin) {
                for (k = 0; k < NQ; ++k) w->trial[k] += RC(0.5) * d * d * (w->t[k] - w->tp[k]) / (lam - lam_tp);
                for (k = 0; k < N; ++k) {
                    if (w->trial[k] <= w->lb) w->trial[k] = RC(0.5) * (q[k] + w->lb);
                }
            }
        }
        at_lambda(w, target);
        accepted = newton_to(w, w->trial, w->p, MAX_NEWTON, target < 1 ? PATH_TOL : STEP_TOL, &contraction, &low) && low > CRITICAL_TOL && contraction <= CONTRACTION &&
                   SQRT(RC(N)) * distance(w->trial, w->y) <= CORRECTOR_RATIO * predicted + JUMP_FLOOR && max_diff(w->trial, q) <= MAX_DQ;
        if (accepted) {
            copy(q, w->trial, NQ);
            copy(w->tp, w->t, NQ);
            lam_tp = lam;
            previous = 1;
            lam = target;
            out->steps++;
            have = 0;
            factored = 1;
            if (contraction < RC(0.1)) h = RC(2.0) * h < H_MAX ? RC(2.0) * h : H_MAX;
            continue;
        }
        h *= RC(0.5);
        if (h >= H_MIN) continue;
        if (near_bound(w, q)) return ESBA_OUT_OF_DOMAIN;
        if (!snap(w, q, &lam, ramp_id, out)) return ESBA_NOT_CONVERGED;
        have = 0;
        previous = 0;
        h = H_MAX;
    }
    return lam < 1 ? ESBA_NOT_CONVERGED : ESBA_OK;
}

/* ---------------------------------------------------------------- results */

static void zero_result({{NAME}}_result *out) {
    int k;
    for (k = 0; k < NQ; ++k) out->q[k] = RC(0.0);
    for (k = 0; k < 9; ++k) out->rotation[k] = RC(0.0);
    out->total_angle = out->total_side = out->total_twist = out->pressure = out->energy = out->gradient_norm = out->min_pivot = RC(0.0);
    out->tip[0] = out->tip[1] = out->tip[2] = RC(0.0);
    out->status = ESBA_OK;
    out->iterations = out->steps = out->snaps = out->sideways = 0;
    out->snap_ramp = -1;
    out->snap_at = out->snap_from = out->snap_to = out->snap_side = RC(0.0);
    out->flags = 0;
}

/* Where the in-plane angles (with the tip's x, the pressure and the payloads) lie outside the
 * model's range: the ESBA_FLAG_* bits, by the rules of esba.model.validity.assess. */
static int range_flags(const {{NAME}}_params *a, const {{NAME}}_loads *l, const REAL *q, REAL tip_x, REAL pressure) {
    int k, flags = 0;
    for (k = 0; k < N; ++k) {
        REAL axial = RC(2.0) * a->r1 * RC(N) * q[k] / a->L;
        REAL num = a->L * a->r2 * a->r2 + RC(N) * a->r1 * a->r1 * a->r1 * q[k];
        REAL den = a->L + RC(N) * (a->d + a->r1) * q[k];
        REAL radius = den > 0 ? SQRT((num > 0 ? num : RC(0.0)) / den) : RC(0.0);
        if (FABS(axial) > STRAIN_LIMIT) flags |= ESBA_FLAG_AXIAL_STRAIN;
        if (FABS((radius - a->r2) / (a->r1 - a->r2)) > STRAIN_LIMIT) flags |= ESBA_FLAG_RADIAL_STRAIN;
    }
    if (FABS(sum_n(q)) > MAX_BEND) flags |= ESBA_FLAG_TOTAL_BEND;
    if (tip_x < 0) flags |= ESBA_FLAG_TIP_BEHIND_BASE;
    if (pressure > PRESSURE_LIMIT) flags |= ESBA_FLAG_PRESSURE_RANGE;
    (void)l;
{{PAYLOAD_FLAG}}    return flags;
}

/* Fill out from q at w->p (the full loads); the status of a converged state: stable or not. */
static int finish(WORK *w, const {{NAME}}_params *a, const {{NAME}}_loads *l, const REAL *q, REAL pressure, {{NAME}}_result *out) {
    int k, ok;
    for (k = 0; k < NQ; ++k) out->q[k] = q[k];
    out->total_angle = sum_n(q);
    out->total_side = sum_n(q + N);
    out->total_twist = sum_n(q + 2 * N);
    out->pressure = pressure;
    eval_kinematics(w, q, a->L, NULL);
    copy(out->tip, w->tip, 3);
    copy(out->rotation, w->rot, 9);
    out->energy = eval_energy(w, q, w->p, NULL);
    ok = eval_newton(w, q, w->p) && factor(w, RC(0.0));
    out->gradient_norm = ok ? max_abs(w->g, NQ) : RC(0.0);
    out->min_pivot = ok ? w->rel : RC(0.0);
    out->iterations = w->iterations;
    if (!all_finite(out->tip, 3) || !all_finite(out->rotation, 9) || !isfinite(out->energy)) {
        out->tip[0] = out->tip[1] = out->tip[2] = out->energy = RC(0.0);
        for (k = 0; k < 9; ++k) out->rotation[k] = RC(0.0);
        return ESBA_OUT_OF_DOMAIN;
    }
    out->flags = range_flags(a, l, q, out->tip[0], pressure);
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

static int done({{NAME}}_result *out, int status) {
    if (out != NULL) out->status = status;
    return status;
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
    a->EI_side = RC({{EI_SIDE}});
    a->GJ = RC({{GJ}});
}

void {{NAME}}_default_loads({{NAME}}_loads *l) {
    if (l == NULL) return;
    l->pressure = RC(0.0);
{{DEFAULT_LOADS}}}

static int check_from(const WORK *w, const {{NAME}}_state *from) {
    int status;
    if (from == NULL) return ESBA_OK;
    status = check_loads(&from->loads);
    if (status != ESBA_OK) return status;
    if (!all_finite(from->q, NQ)) return ESBA_BAD_INPUT;
    return inside(w, from->q) ? ESBA_OK : ESBA_OUT_OF_DOMAIN;
}

/* The load history to l, leaving the state reached in w->lo. */
static int history(WORK *w, const {{NAME}}_params *a, const {{NAME}}_loads *l, const {{NAME}}_state *from, {{NAME}}_result *out) {
    int k, status;
    if (from != NULL) {
        copy(w->lo, from->q, NQ);
        pack(a, &from->loads, RC(1.0), RC(1.0), w->p0);
        pack(a, l, RC(1.0), RC(1.0), w->dp);
        for (k = 0; k < NP; ++k) w->dp[k] -= w->p0[k];
        return ramp(w, w->lo, 2, out);
    }
    for (k = 0; k < NQ; ++k) w->lo[k] = RC(0.0);
    pack(a, l, RC(0.0), RC(0.0), w->p0);
    pack(a, l, RC(1.0), RC(0.0), w->dp);
    for (k = 0; k < NP; ++k) w->dp[k] -= w->p0[k];
    status = ramp(w, w->lo, 0, out);
    if (status != ESBA_OK) return status;
    pack(a, l, RC(1.0), RC(0.0), w->p0);
    pack(a, l, RC(1.0), RC(1.0), w->dp);
    for (k = 0; k < NP; ++k) w->dp[k] -= w->p0[k];
    return ramp(w, w->lo, 1, out);
}

int {{NAME}}_equilibrium(int n, const {{NAME}}_params *a, const {{NAME}}_loads *l, const {{NAME}}_state *from, {{NAME}}_result *out, WORK *w) {
    int status = begin(n, a, l, out, w), verdict;
    if (status != ESBA_OK) return done(out, status);
    status = check_from(w, from);
    if (status != ESBA_OK) return done(out, status);
    status = history(w, a, l, from, out);
    pack(a, l, RC(1.0), RC(1.0), w->p);
    verdict = finish(w, a, l, w->lo, l->pressure, out);
    if (status != ESBA_OK) return done(out, status);
    if (verdict != ESBA_OK) return done(out, verdict);
    if (out->sideways > 0) return done(out, ESBA_BUCKLED);
    return done(out, out->snaps > 0 ? ESBA_SNAPPED : ESBA_OK);
}

int {{NAME}}_equilibrium_batch(int n, int count, const {{NAME}}_params *a, const {{NAME}}_loads *l, {{NAME}}_result *out, WORK *w) {
    int i, good = 0;
    if (count < 0 || a == NULL || l == NULL || out == NULL || w == NULL) return -1;
    for (i = 0; i < count; ++i) {
        int status = {{NAME}}_equilibrium(n, a + i, l + i, NULL, out + i, w);
        if (status == ESBA_OK || status == ESBA_SNAPPED || status == ESBA_BUCKLED) ++good;
    }
    return good;
}

int {{NAME}}_newton(int n, const {{NAME}}_params *a, const {{NAME}}_loads *l, const REAL *q0, {{NAME}}_result *out, WORK *w) {
    REAL contraction, low;
    int status = begin(n, a, l, out, w), converged;
    if (status != ESBA_OK) return done(out, status);
    if (q0 == NULL || !all_finite(q0, NQ)) return done(out, ESBA_BAD_INPUT);
    if (!inside(w, q0)) return done(out, ESBA_OUT_OF_DOMAIN);
    copy(w->lo, q0, NQ);
    pack(a, l, RC(1.0), RC(1.0), w->p);
    converged = newton(w, w->lo, w->p, 4 * MAX_NEWTON, &contraction, &low);
    if (!converged) {
        copy(w->lo, q0, NQ);
        status = near_bound(w, w->lo) ? ESBA_OUT_OF_DOMAIN : ESBA_NOT_CONVERGED;
    }
    pack(a, l, RC(1.0), RC(1.0), w->p);
    converged = finish(w, a, l, w->lo, l->pressure, out);
    return done(out, status != ESBA_OK ? status : converged);
}

{{INVERSE}}

/* Gauss-Jordan inverse of the 6 x 6 c into k with partial pivoting; 0 when c is singular
 * (a pivot below SINGULAR_TOL of the largest entry). */
static int invert6(REAL (*c)[6], REAL (*k)[6]) {
    REAL a[6][12], big = RC(0.0);
    int i, j, r;
    for (i = 0; i < 6; ++i) {
        for (j = 0; j < 6; ++j) {
            a[i][j] = c[i][j];
            a[i][j + 6] = i == j ? RC(1.0) : RC(0.0);
            if (FABS(c[i][j]) > big) big = FABS(c[i][j]);
        }
    }
    if (!(big > 0)) return 0;
    for (j = 0; j < 6; ++j) {
        int best = j;
        REAL piv;
        for (r = j + 1; r < 6; ++r) {
            if (FABS(a[r][j]) > FABS(a[best][j])) best = r;
        }
        if (!(FABS(a[best][j]) > RC({{SINGULAR_TOL}}) * big)) return 0;
        if (best != j) {
            for (i = 0; i < 12; ++i) {
                REAL t = a[j][i];
                a[j][i] = a[best][i];
                a[best][i] = t;
            }
        }
        piv = a[j][j];
        for (i = 0; i < 12; ++i) a[j][i] /= piv;
        for (r = 0; r < 6; ++r) {
            REAL f = a[r][j];
            if (r == j || f == 0) continue;
            for (i = 0; i < 12; ++i) a[r][i] -= f * a[j][i];
        }
    }
    for (i = 0; i < 6; ++i) {
        for (j = 0; j < 6; ++j) k[i][j] = RC(0.5) * (a[i][j + 6] + a[j][i + 6]);
    }
    return all_finite(&k[0][0], 36);
}

int {{NAME}}_stiffness(int n, const {{NAME}}_params *a, const {{NAME}}_loads *l, const REAL *q, {{NAME}}_stiffness_result *out, WORK *w) {
    int i, j, k, status;
    if (out == NULL || w == NULL) return ESBA_BAD_INPUT;
    for (i = 0; i < 6; ++i) {
        for (j = 0; j < 6; ++j) out->compliance[i][j] = out->stiffness[i][j] = RC(0.0);
    }
    out->min_pivot = RC(0.0);
    if (n != N) return ESBA_BAD_SIZE;
    status = check_params(a);
    if (status != ESBA_OK) return status;
    status = check_loads(l);
    if (status != ESBA_OK) return status;
    if (q == NULL || !all_finite(q, NQ)) return ESBA_BAD_INPUT;
    w->lb = lower_bound(a);
    if (!inside(w, q)) return ESBA_OUT_OF_DOMAIN;
    pack(a, l, RC(1.0), RC(1.0), w->p);
    if (!eval_newton(w, q, w->p)) return ESBA_OUT_OF_DOMAIN;
    if (!factor(w, RC(0.0))) return ESBA_UNSTABLE;
    out->min_pivot = w->rel;
    if (!(w->rel > CRITICAL_TOL)) return ESBA_UNSTABLE;
    eval_kinematics(w, q, a->L, NULL);
    for (i = 0; i < 6; ++i) {
        for (k = 0; k < NQ; ++k) w->x[k] = w->jac[k * 6 + i];
        solve(w, w->x, w->t);
        for (j = 0; j < 6; ++j) {
            REAL s = RC(0.0);
            for (k = 0; k < NQ; ++k) s += w->jac[k * 6 + j] * w->t[k];
            out->compliance[j][i] = s;
        }
    }
    for (i = 0; i < 6; ++i) {
        for (j = 0; j < i; ++j) out->compliance[i][j] = out->compliance[j][i] = RC(0.5) * (out->compliance[i][j] + out->compliance[j][i]);
    }
    if (!all_finite(&out->compliance[0][0], 36)) {
        for (i = 0; i < 6; ++i) {
            for (j = 0; j < 6; ++j) out->compliance[i][j] = RC(0.0);
        }
        return ESBA_UNSTABLE;
    }
    if (NQ >= 6 && !invert6(out->compliance, out->stiffness)) {
        for (i = 0; i < 6; ++i) {
            for (j = 0; j < 6; ++j) out->stiffness[i][j] = RC(0.0);
        }
    }
    return ESBA_OK;
}

static int eval_begin(int n, const {{NAME}}_params *a, const {{NAME}}_loads *l, const REAL *q, const REAL *result, WORK *w) {
    int status;
    if (w == NULL || result == NULL || q == NULL) return ESBA_BAD_INPUT;
    if (n != N) return ESBA_BAD_SIZE;
    status = check_params(a);
    if (status != ESBA_OK) return status;
    if (l != NULL) {
        status = check_loads(l);
        if (status != ESBA_OK) return status;
    }
    if (!all_finite(q, NQ)) return ESBA_BAD_INPUT;
    w->lb = lower_bound(a);
    if (!inside(w, q)) return ESBA_OUT_OF_DOMAIN;
    return ESBA_OK;
}

int {{NAME}}_energy(int n, const {{NAME}}_params *a, const {{NAME}}_loads *l, const REAL *q, REAL *energy, REAL *terms, WORK *w) {
    int status = eval_begin(n, a, l, q, energy, w);
    if (status != ESBA_OK) return status;
    if (l == NULL) return ESBA_BAD_INPUT;
    pack(a, l, RC(1.0), RC(1.0), w->p);
    *energy = eval_energy(w, q, w->p, terms);
    return isfinite(*energy) ? ESBA_OK : ESBA_OUT_OF_DOMAIN;
}

int {{NAME}}_gradient(int n, const {{NAME}}_params *a, const {{NAME}}_loads *l, const REAL *q, REAL *gradient, WORK *w) {
    int status = eval_begin(n, a, l, q, gradient, w);
    if (status != ESBA_OK) return status;
    if (l == NULL) return ESBA_BAD_INPUT;
    pack(a, l, RC(1.0), RC(1.0), w->p);
    if (!eval_newton(w, q, w->p)) return ESBA_OUT_OF_DOMAIN;
    copy(gradient, w->g, NQ);
    return ESBA_OK;
}

int {{NAME}}_hessian(int n, const {{NAME}}_params *a, const {{NAME}}_loads *l, const REAL *q, REAL *hessian, WORK *w) {
    int status = eval_begin(n, a, l, q, hessian, w);
    if (status != ESBA_OK) return status;
    if (l == NULL) return ESBA_BAD_INPUT;
    pack(a, l, RC(1.0), RC(1.0), w->p);
    if (!eval_newton(w, q, w->p)) return ESBA_OUT_OF_DOMAIN;
    copy(hessian, w->h, NQ * NQ);
    return ESBA_OK;
}

int {{NAME}}_tip(int n, const {{NAME}}_params *a, const REAL *q, REAL *tip, REAL *rotation, REAL *points, WORK *w) {
    int status = eval_begin(n, a, NULL, q, tip, w);
    if (status != ESBA_OK) return status;
    eval_kinematics(w, q, a->L, points);
    copy(tip, w->tip, 3);
    if (rotation != NULL) copy(rotation, w->rot, 9);
    return all_finite(tip, 3) && all_finite(w->rot, 9) ? ESBA_OK : ESBA_OUT_OF_DOMAIN;
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
    case ESBA_BUCKLED: return "buckled";
    default: return "unknown";
    }
}

const char *{{NAME}}_flag_name(int flag) {
    switch (flag) {
{{FLAG_CASES}}    default: return "unknown";
    }
}
