/* fmu_src/ballinshell.c: the native BallInShell FMU's model (the FMI plumbing is
 * fmu_src/native/fmi2.c; the variables come from ballmill/fmi/interface.py through the
 * generated BallInShell_interface.h, the Butcher tableaus from integrators.py through
 * the generated bm_tableaus.h).
 *
 * What fmu_src/ballinshell_fmu.py does with ballmill.physics, in C on the compiled
 * kernel (ballmill/physics/_kernel.c, #included: its right-hand side, outputs and
 * integrators, which round like the Python path): the ball's state between
 * communication points is integrated along the platform acceleration that the input
 * reconstruction fits through the last samples (one place: the "input reconstruction"
 * section), redone along the interpolating fit once the next inputs are known (the
 * predictor-corrector: "corrected history"), and the contact/slip signals are judged
 * at communication points with the true inputs (one place: "validity signals").
 *
 * Both formulations: the vector one (state n, omega) and the paper's (xC, yC, omega;
 * lower hemisphere, stops within 0.02 (R - r) of the equator), both in the kernel.
 *
 * motion = 2 (a chamber that moves in 3-D and turns): the samples also carry
 * z1O..az1O, Omega, Omega', Q; the "motion = 2" section reconstructs the chamber's motion as
 * turning/reconstruction.py does, the ball is the general model of turning/model.py (the
 * kernel's bmg_poly_rhs along the fit, bmg_outputs at the reconstructed chamber state), and
 * everything else (node choice, corrector, validity, coupling_error, FMU states) is shared
 * with motion = 1, whose arithmetic is unchanged.
 *
 * The call semantics of docs/conformance.md, as ballinshell_fmu.py and
 * platform.py have them: an input history of `points` + 6 samples; the fit's nodes chosen
 * at least h/2 apart, newest first (one node: the newest sample's Taylor polynomial);
 * positions fitted relative to the newest node; mode 1 leaves out position (and velocity)
 * rows that round-off would spoil; mode 2 keeps every sample; mode 4 fits
 * measured accelerations; mode 1's consistency check flags (and on a jump restarts the
 * history); the corrector runs over all samples in the node window; coupling_error adds
 * the drift of input noise (modes 2, 4); the validity latch (valid, t_invalid); the work
 * bounds (delta <= r, c_drag <= 1e4 m omega0, 20000 internal steps, RK4's h_fixed).
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmu_model.h"
#include "BallInShell_interface.h"
#include "bm_tableaus.h"
#include "_kernel.c"

#define MAX_POINTS 6        /* the most nodes of a fit (positions only) */
#define HISTORY_EXTRA 6     /* samples kept beyond `points`, for the node choice after short steps */
#define MAX_SAMPLES (MAX_POINTS + HISTORY_EXTRA)
#define MAX_INTERNAL_STEPS 20000 /* work bound: internal steps of one integration in a doStep */
#define DRAG_LIMIT 1e4      /* c_drag <= DRAG_LIMIT m omega0 */
#define A_REL 0.01          /* consistency: relative part of the accepted acceleration error */
#define A_RES 1e-6          /* m/s2: acceleration error input round-off may cause */
#define GAIN_POSITIONS 187.0 /* max sum |l_i''| of the 6-node quintic (unit spacing) */
#define NEVER 1e300         /* t_invalid while the model is valid */
#define Z_HYSTERESIS 1e-10  /* event indicators' hysteresis, relative to the ball's weight m max(g, 1 m/s2) */
/* contact_model = 2: the hybrid ball's event driver (events.integrate's defaults, hybrid.Contact's slip_eps
 * and creep_eps) */
#define HYB_BURST 100       /* Zeno guard: more than HYB_BURST events within HYB_BURST / HYB_MAX_RATE s */
#define HYB_MAX_RATE 1e4    /* events/s */
#define HYB_SCAN 3          /* interior points of the guards' Hermite scan */
#define HYB_XTOL 1e-11      /* s: the event's bracket */
#define HYB_SLIP_EPS 1e-6   /* m/s: sliding ends below this slip speed */
#define HYB_HOP_MIN_ULPS 1e4 /* hybrid.HOP_MIN_ULPS: a rebound whose hop the gap cannot resolve is rest */
#define HYB_MAX_STEPS 1000000 /* internal steps of one interval, at most (integrators.Integrator's default) */

/* one sample of the inputs (in the order of turning/reconstruction.py's NAMES after t); the
 * fields after ay are used with motion = 2 only (0 with motion = 1) */
typedef struct {
    double t, x, y, vx, vy, ax, ay;
    double z, vz, az, om[3], omd[3], q[9];
} sample;
#define SAMPLE_VALUES 25 /* doubles in a sample */

typedef struct {
    double t;
    double y[BMH_NZ]; /* the formulation's state (n, omega or xC, yC, omega); contact_model = 2 the
                         mode's: rolling (n, omega), sliding and flight (C, v_C, omega, W, E_friction) */
    double h; /* next internal step of the adaptive methods; NAN: choose one */
    int mode; /* contact_model = 2: BMH_FLIGHT, BMH_ROLLING, BMH_SLIDING (contact_model = 1: BMH_ROLLING) */
    double book[BMH_NBOOK]; /* contact_model = 2: the hybrid run's bookkeeping (bmh_interval's) */
} ball_state;

/* the reconstructed platform motion over the coming step (InputReconstruction's fit) */
typedef struct {
    double t0, hs;
    int n;                       /* coefficients of x(tau), y(tau) */
    double cx[3 * 2], cy[3 * 2]; /* in tau = (t - t0) / hs */
    int dropped;                 /* mode 1: the positions were left out (X, w below) */
    double X, w;
    double mp[BM_NMP];           /* a(t) as the kernel's BM_POLY cubic: t0, x0..x3, y0..y3 */
    /* motion = 2 (ChamberReconstruction._fit): A(s) quintics, Omega(s) cubics in s = t - t0,
     * the newest Q, and kin(t)'s coefficients for the kernel (bmg_poly_kin) */
    double pos[3][6], om[3][4], Q[9], poly[BMG_NPOLY];
} fit;

typedef struct {
    /* configuration: built by setup from the parameters */
    bm_problem P;
    bm_tab T;
    int motion;      /* 1 translation (the kernel's bm_* functions), 2 general (bmg_*) */
    bmg_problem G;   /* motion = 2: the integrator settings (G.base) and the general model's constants */
    int mode, points, correct;
    int contact; /* contact_model: 1 rolling only, 2 hybrid (rolling, sliding, flight, impacts) */
    bmh_problem H; /* contact_model = 2: the hybrid ball, its chamber set to each step's fit (hybrid_chamber) */
    double max_step, R, d, mu, omega_small, a_tol;
    double z_eps; /* N: the event indicators' hysteresis (Model Exchange: me_eval) */
    /* caches, not state (a calloc'ed instance starts them empty): the last fit's system, by
     * its size, derivative orders and nodes, with its inverse (fit_inverse; memo_n 0: empty),
     * and the powers hs^2 .. hs^5 of the last node spacing (hs_powers; memo_hs 0: empty) */
    int memo_n, memo_ders[6];
    double memo_taus[6], memo_inv[6][6];
    double memo_hs, memo_hs_pow[4];
    /* dynamic state: what FMU states carry */
    ball_state state; /* the predicted state at the instance's time */
    int n_samples;
    sample samples[MAX_SAMPLES];
    double h_next; /* the coming step the fit's nodes are chosen for */
    int n_hist;
    ball_state hist[MAX_SAMPLES + 1]; /* corrected states at the sample times */
    int has_t_prev;
    double t_prev;
    int confirmed_contact, confirmed_rolling;
    int warned, resolution_warned, inconsistency_warned, ignored_warned;
    double noise_sum; /* coupling_error's drift: sum of (da H)^2 */
    int has_a_mid;
    double a_mid[3]; /* (t, ax, ay) of the previous fit mid-way through its interval */
    int has_fed;
    sample fed; /* the inputs of the last feedthrough refresh since the last step (inputs_set) */
} ball_in_shell;

static const char *const INPUT_NAMES[SAMPLE_VALUES - 1] = {
    "x1O", "y1O", "vx1O", "vy1O", "ax1O", "ay1O", "z1O", "vz1O", "az1O", "Omega_x", "Omega_y", "Omega_z",
    "Omega_dot_x", "Omega_dot_y", "Omega_dot_z", "Q11", "Q12", "Q13", "Q21", "Q22", "Q23", "Q31", "Q32", "Q33"};
/* the inputs of motion = 2 (after the first six) with their defaults, by value reference */
static const int MOTION_VR[SAMPLE_VALUES - 7] = {
    VR_z1O, VR_vz1O, VR_az1O, VR_Omega_x, VR_Omega_y, VR_Omega_z, VR_Omega_dot_x, VR_Omega_dot_y,
    VR_Omega_dot_z, VR_Q11, VR_Q12, VR_Q13, VR_Q21, VR_Q22, VR_Q23, VR_Q31, VR_Q32, VR_Q33};
#define Q_TOL 1e-6 /* orthonormality of the orientation input (reconstruction.Q_TOL) */

/* ===================================================================== input reconstruction
 * platform.InputReconstruction: the samples of the window, the polynomial fit through
 * them (a confluent Vandermonde system in tau), a(t) and the motion's state at t. */

static double ulp(double x)
{
    return ldexp(1.0, -52) * fmax(fabs(x), 1e-300);
}

/* the consistency check of two samples H apart over n axes (platform.worst_residual): p[k]
 * and q[k] hold the samples' (x, v, a) of axis k, a_mag the larger |a| of the two. -1 when
 * every axis agrees; else the axis whose residual exceeds its limit by the largest factor,
 * with the residual in *r, its limit in *limit and *jump = 6 |r| / H^2 > a_tol + |a| */
static int worst_residual(double a_tol, double H, double a_mag, int n, const double p[][3], const double q[][3],
                          double *r_worst, double *limit_worst, int *jump)
{
    int worst = -1;
    double worst_ratio = 0.0;
    *r_worst = 0.0;
    *limit_worst = 0.0;
    *jump = 0;
    for (int k = 0; k < n; k++) {
        double r = q[k][0] - p[k][0] - 0.5 * H * (p[k][1] + q[k][1]) + H * H * (q[k][2] - p[k][2]) / 12.0;
        double a_scale = a_tol + A_REL * a_mag;
        double limit = a_scale * H * H / 6.0 + 8.0 * ulp(fmax(fabs(p[k][0]), fabs(q[k][0])));
        if (fabs(r) > limit && (worst < 0 || fabs(r) / limit > worst_ratio)) {
            worst = k;
            worst_ratio = fabs(r) / limit;
            *r_worst = r;
            *limit_worst = limit;
        }
    }
    if (worst >= 0) *jump = 6.0 * fabs(*r_worst) / (H * H) > a_tol + a_mag;
    return worst;
}

/* the consistency of samples p and q (mode 1, platform.InputReconstruction.inconsistency):
 * 0, or 1 with the description in why and *jump set when the history must restart */
static int recon_inconsistency(const ball_in_shell *b, const sample *p, const sample *q, int *jump, char *why,
                               size_t size)
{
    double H = q->t - p->t;
    double a_mag = fmax(hypot(p->ax, p->ay), hypot(q->ax, q->ay));
    const double pv[2][3] = {{p->x, p->vx, p->ax}, {p->y, p->vy, p->ay}};
    const double qv[2][3] = {{q->x, q->vx, q->ax}, {q->y, q->vy, q->ay}};
    double rw, lw;
    int worst = worst_residual(b->a_tol, H, a_mag, 2, pv, qv, &rw, &lw, jump);
    if (worst < 0) return 0;
    char c[6][32], tp[32], tq[32];
    const char ax = worst ? 'y' : 'x';
    snprintf(why, size, "inputs %c1O, v%c1O, a%c1O disagree between t = %s s (%c1O = %s m, v%c1O = %s m/s, "
             "a%c1O = %s m/s2) and t = %s s (%c1O = %s m, v%c1O = %s m/s, a%c1O = %s m/s2): position residual "
             "%.3g m, accepted |r| <= %.3g m (input_tol = %g m/s2 + %g |a| of acceleration)%s",
             ax, ax, ax, fmu_repr(p->t, tp), ax, fmu_repr(pv[worst][0], c[0]), ax, fmu_repr(pv[worst][1], c[1]),
             ax, fmu_repr(pv[worst][2], c[2]), fmu_repr(q->t, tq), ax, fmu_repr(qv[worst][0], c[3]), ax,
             fmu_repr(qv[worst][1], c[4]), ax, fmu_repr(qv[worst][2], c[5]), rw, lw, b->a_tol, A_REL,
             *jump ? "; the reconstruction restarts at the newer sample" : "");
    return 1;
}

static void chamber_centre(const sample *p, double R, double A[3], double vA[3], double aA[3]);

/* motion = 2, mode 1 (ChamberReconstruction.inconsistency): the chamber centres of samples p
 * and q, per axis with recon_inconsistency's residual and thresholds; 0, or 1 with the
 * description in why and *jump set when the history must restart */
static int general_inconsistency(const ball_in_shell *b, const sample *p, const sample *q, int *jump, char *why,
                                 size_t size)
{
    double Ap[3], vp[3], ap[3], Aq[3], vq[3], aq[3];
    chamber_centre(p, b->R, Ap, vp, ap);
    chamber_centre(q, b->R, Aq, vq, aq);
    double H = q->t - p->t;
    double a_mag = fmax(sqrt(ap[0] * ap[0] + ap[1] * ap[1] + ap[2] * ap[2]),
                        sqrt(aq[0] * aq[0] + aq[1] * aq[1] + aq[2] * aq[2]));
    const double pv[3][3] = {{Ap[0], vp[0], ap[0]}, {Ap[1], vp[1], ap[1]}, {Ap[2], vp[2], ap[2]}};
    const double qv[3][3] = {{Aq[0], vq[0], aq[0]}, {Aq[1], vq[1], aq[1]}, {Aq[2], vq[2], aq[2]}};
    double rw, lw;
    int worst = worst_residual(b->a_tol, H, a_mag, 3, pv, qv, &rw, &lw, jump);
    if (worst < 0) return 0;
    char e[6][32], tp[32], tq[32];
    const char c = "xyz"[worst];
    snprintf(why, size, "the chamber centre A = O + Q (0, 0, R) of the inputs (x1O..az1O, Omega, Omega_dot, Q) "
             "disagrees in %c between t = %s s (A%c = %s m, vA%c = %s m/s, aA%c = %s m/s2) and t = %s s (A%c = %s m, "
             "vA%c = %s m/s, aA%c = %s m/s2): position residual %.3g m, accepted |r| <= %.3g m (input_tol = %g "
             "m/s2 + %g |a| of acceleration)%s",
             c, fmu_repr(p->t, tp), c, fmu_repr(Ap[worst], e[0]), c, fmu_repr(vp[worst], e[1]), c,
             fmu_repr(ap[worst], e[2]), fmu_repr(q->t, tq), c, fmu_repr(Aq[worst], e[3]), c,
             fmu_repr(vq[worst], e[4]), c, fmu_repr(aq[worst], e[5]), rw, lw, b->a_tol, A_REL,
             *jump ? "; the reconstruction restarts at the newer sample" : "");
    return 1;
}

/* push the inputs seen at t; a second sample at the same t replaces the first.
 * -1 and why when the sample is refused (state unchanged); 1 and why when it is
 * inconsistent with the one before (mode 1; the history then restarts on a jump); 0 */
/* reconstruction.rotation_problem: 0 when q (row-major) is a rotation within Q_TOL, else 1
 * and what is wrong in why */
static int rotation_problem(const double *q, char *why, size_t size)
{
    double worst = -1.0, wv = 0.0;
    int wi = 0, wj = 0;
    char a[32], e[6][32];
    for (int i = 0; i < 3; i++)
        for (int j = i; j < 3; j++) {
            double v = (q[3 * i] * q[3 * j] + q[3 * i + 1] * q[3 * j + 1]) + q[3 * i + 2] * q[3 * j + 2];
            double err = fabs(v - (i == j ? 1.0 : 0.0));
            if (err > worst) {
                worst = err; wi = i; wj = j; wv = v;
            }
        }
    if (worst > Q_TOL) {
        int lo = wi < wj ? wi : wj, hi = wi < wj ? wj : wi;
        char rows[400];
        snprintf(rows, sizeof rows, "Q%d1 = %s, Q%d2 = %s, Q%d3 = %s", lo + 1, fmu_repr(q[3 * lo], e[0]), lo + 1,
                 fmu_repr(q[3 * lo + 1], e[1]), lo + 1, fmu_repr(q[3 * lo + 2], e[2]));
        if (hi != lo) {
            size_t used = strlen(rows);
            snprintf(rows + used, sizeof rows - used, ", Q%d1 = %s, Q%d2 = %s, Q%d3 = %s", hi + 1,
                     fmu_repr(q[3 * hi], e[3]), hi + 1, fmu_repr(q[3 * hi + 1], e[4]), hi + 1,
                     fmu_repr(q[3 * hi + 2], e[5]));
        }
        snprintf(why, size, "input Q is not a rotation matrix: row %d . row %d = %s, expected %s within %g (%s)",
                 wi + 1, wj + 1, fmu_repr(wv, a), wi == wj ? "1.0" : "0.0", Q_TOL, rows);
        return 1;
    }
    double det = (q[0] * (q[4] * q[8] - q[5] * q[7]) - q[1] * (q[3] * q[8] - q[5] * q[6]))
                 + q[2] * (q[3] * q[7] - q[4] * q[6]);
    if (!(det > 0.0)) {
        snprintf(why, size, "input Q is not a rotation matrix: det Q = %s, expected +1 (a reflection)",
                 fmu_repr(det, a));
        return 1;
    }
    return 0;
}

/* the inputs at t as a sample (ReconstructionHistory.push's checks): 0, or -1 with the reason
 * for a value that is not finite or a Q that is not a rotation (motion = 2) */
static int read_sample(const ball_in_shell *b, const double *v, double t, sample *s, char *why, size_t size)
{
    const sample in = {t, v[VR_x1O], v[VR_y1O], v[VR_vx1O], v[VR_vy1O], v[VR_ax1O], v[VR_ay1O],
                       0.0, 0.0, 0.0, {0.0, 0.0, 0.0}, {0.0, 0.0, 0.0}, {0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0}};
    *s = in;
    const double *vals = &s->x;
    char a[32], c[32];
    int n_values = 6;
    if (b->motion == 2) {
        double *extra = &s->z;
        for (int i = 0; i < SAMPLE_VALUES - 7; i++) extra[i] = v[MOTION_VR[i]];
        n_values = SAMPLE_VALUES - 1;
    }
    for (int i = 0; i < n_values; i++)
        if (!isfinite(vals[i])) {
            snprintf(why, size, "input %s must be finite, got %s at t = %s s", INPUT_NAMES[i],
                     fmu_repr(vals[i], a), fmu_repr(t, c));
            return -1;
        }
    if (b->motion == 2) {
        char problem[700];
        if (rotation_problem(s->q, problem, sizeof problem)) {
            snprintf(why, size, "%s at t = %s s", problem, fmu_repr(t, c));
            return -1;
        }
    }
    return 0;
}

static int recon_push(ball_in_shell *b, const double *v, double t, char *why, size_t size)
{
    sample s;
    char a[32], c[32];
    if (read_sample(b, v, t, &s, why, size)) return -1;
    if (b->n_samples && t < b->samples[b->n_samples - 1].t) {
        snprintf(why, size, "inputs must come in time order: got t = %s s after t = %s s", fmu_repr(t, a),
                 fmu_repr(b->samples[b->n_samples - 1].t, c));
        return -1;
    }
    sample prev;
    memset(&prev, 0, sizeof prev);
    int has_prev = 0;
    if (b->n_samples && t == b->samples[b->n_samples - 1].t) {
        b->samples[b->n_samples - 1] = s;
        if (b->n_samples > 1) {
            prev = b->samples[b->n_samples - 2];
            has_prev = 1;
        }
    } else {
        if (b->n_samples) {
            prev = b->samples[b->n_samples - 1];
            has_prev = 1;
        }
        if (b->n_samples == b->points + HISTORY_EXTRA) { /* the oldest leaves (before the append: the array holds no more) */
            memmove(b->samples, b->samples + 1, (size_t)(b->n_samples - 1) * sizeof(sample));
            b->n_samples--;
        }
        b->samples[b->n_samples++] = s;
    }
    if (b->mode == 1 && has_prev && b->n_samples > 1) {
        int jump;
        const sample *now = &b->samples[b->n_samples - 1];
        if (b->motion == 2 ? general_inconsistency(b, &prev, now, &jump, why, size)
                           : recon_inconsistency(b, &prev, now, &jump, why, size)) {
            if (jump) {
                b->samples[0] = b->samples[b->n_samples - 1];
                b->n_samples = 1;
            }
            return 1;
        }
    }
    return 0;
}

/* the samples the fit uses: the newest and, walking back, each one at least h/2 before the
 * node chosen last, up to `points` (InputReconstruction.nodes); indices oldest first */
static int recon_nodes(const ball_in_shell *b, int idx[MAX_POINTS])
{
    double spacing = 0.5 * b->h_next;
    int rev[MAX_POINTS], n = 0;
    rev[n++] = b->n_samples - 1;
    for (int i = b->n_samples - 2; i >= 0; i--) {
        if (n == b->points) break;
        if (b->samples[rev[n - 1]].t - b->samples[i].t >= spacing) rev[n++] = i;
    }
    for (int i = 0; i < n; i++) idx[i] = rev[n - 1 - i];
    return n;
}

/* the inverse of M (n <= 6), correctly rounded to doubles as the Python path computes it
 * exactly in rationals: Gauss-Jordan with partial pivoting in quadruple precision
 * (__float128: 113-bit mantissas; its errors, ~1e-34 times the matrix's condition number,
 * stay far below half an ulp of a double even for the 6-node quintic on unequal steps,
 * where long double's 64 bits were not enough), rounded at the end. Compilers without
 * __float128 use long double. 0 when M is singular. */
#if defined(__SIZEOF_FLOAT128__)
typedef __float128 wide;
#else
typedef long double wide;
#endif

static wide wide_abs(wide x)
{
    return x < 0 ? -x : x;
}

static int invert(int n, const double M[6][6], double inv[6][6])
{
    wide A[6][12];
    for (int i = 0; i < n; i++)
        for (int j = 0; j < 2 * n; j++) A[i][j] = j < n ? (wide)M[i][j] : (wide)(j - n == i);
    for (int col = 0; col < n; col++) {
        int piv = col;
        for (int i = col + 1; i < n; i++)
            if (wide_abs(A[i][col]) > wide_abs(A[piv][col])) piv = i;
        if (A[piv][col] == 0) return 0;
        for (int j = 0; j < 2 * n; j++) {
            wide tmp = A[col][j]; A[col][j] = A[piv][j]; A[piv][j] = tmp;
        }
        wide p = A[col][col];
        for (int j = 0; j < 2 * n; j++) A[col][j] /= p;
        for (int i = 0; i < n; i++) {
            wide f = A[i][col];
            if (i == col || f == 0) continue;
            for (int j = 0; j < 2 * n; j++) A[i][j] -= f * A[col][j];
        }
    }
    for (int i = 0; i < n; i++)
        for (int j = 0; j < n; j++) inv[i][j] = (double)A[i][n + j];
    return 1;
}

/* invert() through the instance's memo of the last matrix and its inverse: at equal
 * communication steps the nodes' tau are the same integers at every step, so M repeats
 * bit for bit and the quadruple-precision elimination (in software: most of a doStep's
 * time) runs once. invert() is a function of M's bits alone, so a bitwise-equal M gets
 * the bitwise-equal inverse: results do not change. The memo sits in the configuration
 * part of the data, which setup clears and FMU states never restore. */
/* j (j-1) ... (j-der+1): math.perm(j, der) */
static double perm(int j, int der)
{
    double p = 1.0;
    for (int q = 0; q < der; q++) p *= (double)(j - q);
    return p;
}

/* The inverse of the fit's confluent Vandermonde matrix M[i][j] = perm(j, ders[i]) *
 * taus[i]^(j - ders[i]) (the Python flavour's numpy.linalg.inv, see invert). M depends on
 * (n, ders, taus) alone, which repeat from step to step at a constant communication step, so
 * the last inverse is kept with them and neither M nor its inverse is computed again while
 * they stay bit for bit the same. 0 when M is singular. */
static int fit_inverse(ball_in_shell *b, int n, const int ders[6], const double taus[6], double inv[6][6])
{
    if (n == b->memo_n && memcmp(ders, b->memo_ders, (size_t)n * sizeof *ders) == 0 &&
        memcmp(taus, b->memo_taus, (size_t)n * sizeof *taus) == 0) {
        memcpy(inv, b->memo_inv, sizeof b->memo_inv);
        return 1;
    }
    double M[6][6] = {{0}};
    for (int i = 0; i < n; i++)
        for (int j = ders[i]; j < n; j++) M[i][j] = perm(j, ders[i]) * pow(taus[i], (double)(j - ders[i]));
    memset(inv, 0, sizeof b->memo_inv); /* invert() fills the n x n corner */
    if (!invert(n, M, inv)) return 0;
    b->memo_n = n;
    memcpy(b->memo_ders, ders, (size_t)n * sizeof *ders);
    memcpy(b->memo_taus, taus, (size_t)n * sizeof *taus);
    memcpy(b->memo_inv, inv, sizeof b->memo_inv);
    return 1;
}

/* hs^2, hs^3, hs^4, hs^5 as libm's pow gives them (the Python flavour's hs ** k), computed
 * once per node spacing */
static const double *hs_powers(ball_in_shell *b, double hs)
{
    if (!(hs == b->memo_hs)) {
        for (int j = 0; j < 4; j++) b->memo_hs_pow[j] = pow(hs, (double)(j + 2));
        b->memo_hs = hs;
    }
    return b->memo_hs_pow;
}

/* Python's round(x, 12): the exact binary value rounded to 12 decimals (printf rounds
 * exactly, half to even), read back correctly rounded */
static double round12(double x)
{
    char buf[64];
    if (x == floor(x)) return x; /* whole numbers: already rounded */
    /* within a quarter of 1e-12 of a whole number k (equal steps, up to round-off): every
     * other 12-decimal number lies at least 0.75e-12 from x, so round(x, 12) is k (-0.0
     * for k = 0 and x < 0, as printf and Python give); x - k is exact (Sterbenz) */
    double k = nearbyint(x);
    if (fabs(x - k) < 0.25e-12 && fabs(k) < 1e15) return k;
    snprintf(buf, sizeof buf, "%.12f", x);
    return strtod(buf, NULL);
}

/* sum(row[j] * b[j]), left to right (platform._dot) */
static double dot_lr(const double *row, const double *b, int n)
{
    double acc = row[0] * b[0];
    for (int j = 1; j < n; j++) acc += row[j] * b[j];
    return acc;
}

/* coefficients of the derivative of a polynomial (InputReconstruction._deriv) */
static int deriv(const double *c, int n, double *out)
{
    if (n <= 1) {
        out[0] = 0.0;
        return 1;
    }
    for (int j = 1; j < n; j++) out[j - 1] = (double)j * c[j];
    return n - 1;
}

static double horner(const double *c, int n, double tau)
{
    double acc = 0.0;
    for (int j = n - 1; j >= 0; j--) acc = acc * tau + c[j];
    return acc;
}

/* ===================================================================== motion = 2
 * turning/reconstruction.py: the chamber centre A = O + Q (0, 0, R) with v_A, a_A from each
 * sample, fitted per axis (Hermite quintic through two nodes, or the newest sample's Taylor
 * polynomial), Omega (Hermite cubic through Omega, Omega'), Q over the step by Rodrigues. */

/* reconstruction.centre: A, v_A, a_A of a sample */
static void chamber_centre(const sample *p, double R, double A[3], double vA[3], double aA[3])
{
    double ex = R * p->q[2], ey = R * p->q[5], ez = R * p->q[8];
    double ox = p->om[0], oy = p->om[1], oz = p->om[2], px = p->omd[0], py = p->omd[1], pz = p->omd[2];
    double cx = oy * ez - oz * ey, cy = oz * ex - ox * ez, cz = ox * ey - oy * ex;
    A[0] = p->x + ex; A[1] = p->y + ey; A[2] = p->z + ez;
    vA[0] = p->vx + cx; vA[1] = p->vy + cy; vA[2] = p->vz + cz;
    aA[0] = p->ax + ((py * ez - pz * ey) + (oy * cz - oz * cy));
    aA[1] = p->ay + ((pz * ex - px * ez) + (oz * cx - ox * cz));
    aA[2] = p->az + ((px * ey - py * ex) + (ox * cy - oy * cx));
}

/* ChamberReconstruction._fit and _compile (coefficients in s = t - t0) */
static void general_fit(const ball_in_shell *b, const int *idx, int nn, fit *f)
{
    const sample *nw = &b->samples[idx[nn - 1]];
    double A1[3], v1[3], a1[3];
    chamber_centre(nw, b->R, A1, v1, a1);
    if (b->mode == 3 || nn == 1) {
        for (int k = 0; k < 3; k++) {
            f->pos[k][0] = A1[k]; f->pos[k][1] = v1[k]; f->pos[k][2] = 0.5 * a1[k];
            f->pos[k][3] = 0.0; f->pos[k][4] = 0.0; f->pos[k][5] = 0.0;
            f->om[k][0] = nw->om[k]; f->om[k][1] = nw->omd[k]; f->om[k][2] = 0.0; f->om[k][3] = 0.0;
        }
    } else {
        const sample *old = &b->samples[idx[0]];
        double A0[3], v0[3], a0[3];
        chamber_centre(old, b->R, A0, v0, a0);
        double H = nw->t - old->t;
        double H2 = H * H;
        double H3 = H2 * H;
        double H4 = H3 * H;
        double H5 = H4 * H;
        for (int k = 0; k < 3; k++) {
            double c1 = H * v1[k];
            double c2 = 0.5 * H2 * a1[k];
            double P = ((A0[k] - A1[k]) + c1) - c2;
            double V = (H * v0[k] - c1) + 2.0 * c2;
            double Acc = H2 * a0[k] - 2.0 * c2;
            double c3 = (-10.0 * P - 4.0 * V) - 0.5 * Acc;
            double c4 = (-15.0 * P - 7.0 * V) - Acc;
            double c5 = (-6.0 * P - 3.0 * V) - 0.5 * Acc;
            f->pos[k][0] = A1[k]; f->pos[k][1] = v1[k]; f->pos[k][2] = 0.5 * a1[k];
            f->pos[k][3] = c3 / H3; f->pos[k][4] = c4 / H4; f->pos[k][5] = c5 / H5;
            double e1 = H * nw->omd[k];
            double p = (old->om[k] - nw->om[k]) + e1;
            double q = H * old->omd[k] - e1;
            double e2 = 3.0 * p + q;
            double e3 = 2.0 * p + q;
            f->om[k][0] = nw->om[k]; f->om[k][1] = nw->omd[k]; f->om[k][2] = e2 / H2; f->om[k][3] = e3 / H3;
        }
    }
    f->t0 = nw->t;
    f->hs = 1.0;
    f->n = 0;
    f->dropped = 0;
    memcpy(f->Q, nw->q, sizeof f->Q);
    f->poly[0] = nw->t;
    for (int k = 0; k < 3; k++) {
        const double *p = f->pos[k], *o = f->om[k];
        double *a = f->poly + 1 + 4 * k, *w = f->poly + 13 + 4 * k, *d = f->poly + 25 + 3 * k;
        a[0] = 2.0 * p[2]; a[1] = 6.0 * p[3]; a[2] = 12.0 * p[4]; a[3] = 20.0 * p[5];
        w[0] = o[0]; w[1] = o[1]; w[2] = o[2]; w[3] = o[3];
        d[0] = o[1]; d[1] = 2.0 * o[2]; d[2] = 3.0 * o[3];
    }
}

/* ChamberReconstruction.state: the 38 fields of a ChamberState at t (drive fields 0): the kernel's
 * bmg_poly_state of the fit */
static void general_state(const fit *f, double t, double cs[BMG_NCS])
{
    bmg_poly_state(f->t0, f->pos, f->om, f->Q, t, cs);
}

static int recon_fit(ball_in_shell *b, fit *f)
{
    int idx[MAX_POINTS], nn = recon_nodes(b, idx);
    if (b->motion == 2) {
        general_fit(b, idx, nn, f);
        return 1;
    }
    const sample *newest = &b->samples[idx[nn - 1]];
    double tk = newest->t, x_ref = newest->x, y_ref = newest->y;
    f->t0 = tk;
    f->hs = nn > 1 ? tk - b->samples[idx[nn - 2]].t : 1.0;
    f->dropped = 0;
    if (b->mode == 3 || (nn == 1 && b->mode != 2)) { /* the newest sample's Taylor polynomial */
        f->hs = 1.0;
        f->n = 3;
        f->cx[0] = newest->x; f->cx[1] = newest->vx; f->cx[2] = 0.5 * newest->ax;
        f->cy[0] = newest->y; f->cy[1] = newest->vy; f->cy[2] = 0.5 * newest->ay;
    } else {
        /* kind: 'x' positions; 'f' x, v, a at every node; 'v' v, a at every node and x at the
         * newest; 'a' a at every node and x, v at the newest */
        double inv[6][6], bx[6], by[6], hs = f->hs;
        char kind;
        if (b->mode == 2) {
            kind = 'x';
        } else if (b->mode == 4) {
            kind = 'a';
        } else {
            double X = 0.0, V = 0.0, w = tk - b->samples[idx[0]].t;
            for (int i = 0; i < nn; i++) {
                const sample *q = &b->samples[idx[i]];
                X = fmax(X, fmax(fabs(q->x), fabs(q->y)));
                V = fmax(V, fmax(fabs(q->vx), fabs(q->vy)));
            }
            if (6.0 * ulp(X) / (w * w) <= A_RES) {
                kind = 'f';
            } else {
                f->dropped = 1;
                f->X = X;
                f->w = w;
                kind = 4.0 * ulp(V) / w <= A_RES ? 'v' : 'a';
            }
        }
        int ders[6], n = 0;
        double taus[6];
        for (int i = 0; i < nn; i++) {
            const sample *q = &b->samples[idx[i]];
            int last = i == nn - 1;
            double tau = round12((q->t - tk) / hs);
            if (kind == 'x' || kind == 'f' || last) {
                if (n >= 6) return 0;
                ders[n] = 0; taus[n] = tau; bx[n] = q->x - x_ref; by[n] = q->y - y_ref; n++;
            }
            if (kind == 'x') continue;
            if (kind == 'f' || kind == 'v' || last) {
                if (n >= 6) return 0;
                ders[n] = 1; taus[n] = tau; bx[n] = q->vx * hs; by[n] = q->vy * hs; n++;
            }
            if (n >= 6) return 0;
            ders[n] = 2; taus[n] = tau; bx[n] = q->ax * hs * hs; by[n] = q->ay * hs * hs; n++;
        }
        if (!fit_inverse(b, n, ders, taus, inv)) return 0;
        f->n = n;
        for (int i = 0; i < n; i++) {
            f->cx[i] = dot_lr(inv[i], bx, n);
            f->cy[i] = dot_lr(inv[i], by, n);
        }
        f->cx[0] += x_ref;
        f->cy[0] += y_ref;
    }
    /* a(t) in physical time: the second derivative's coefficients over hs^(j+2) */
    double dx[6], dy[6], ddx[6], ddy[6];
    int n1 = deriv(f->cx, f->n, dx), n2 = deriv(dx, n1, ddx);
    deriv(f->cy, f->n, dy);
    deriv(dy, n1, ddy);
    const double *hs_pow = hs_powers(b, f->hs);
    f->mp[0] = f->t0;
    for (int j = 0; j < 4; j++) {
        f->mp[1 + j] = j < n2 ? ddx[j] / hs_pow[j] : 0.0;
        f->mp[5 + j] = j < n2 ? ddy[j] / hs_pow[j] : 0.0;
    }
    return 1;
}

/* (x, y, vx, vy, ax, ay) of the reconstructed motion at t */
static void recon_state(const fit *f, double t, double o[6])
{
    double dx[6], dy[6], ddx[6], ddy[6], tau = (t - f->t0) / f->hs, hs = f->hs;
    int n1 = deriv(f->cx, f->n, dx), n2 = deriv(dx, n1, ddx);
    deriv(f->cy, f->n, dy);
    deriv(dy, n1, ddy);
    o[0] = horner(f->cx, f->n, tau);
    o[1] = horner(f->cy, f->n, tau);
    o[2] = horner(dx, n1, tau) / hs;
    o[3] = horner(dy, n1, tau) / hs;
    o[4] = horner(ddx, n2, tau) / (hs * hs);
    o[5] = horner(ddy, n2, tau) / (hs * hs);
}

/* a(t) of the fit (the closure of InputReconstruction._compile_accel) */
static void recon_accel(const fit *f, double t, double *ax, double *ay)
{
    const double *p = f->mp;
    double s = t - p[0];
    *ax = p[1] + s * (p[2] + s * (p[3] + s * p[4]));
    *ay = p[5] + s * (p[6] + s * (p[7] + s * p[8]));
}

/* ===================================================================== the ball */
/* Python's x ** 2: libm's pow, which is not always the correctly rounded x * x the
 * compiler would fold pow(x, 2.0) into */
static double py_square(double x)
{
    volatile double two = 2.0;
    return pow(x, two);
}

/* the contact direction n of a state (the formulation's to_nw) */
static void to_n(const ball_in_shell *b, const double *y, double n[3])
{
    if (b->P.form == BM_PAPER) {
        double d = b->d;
        n[0] = y[0] / d;
        n[1] = y[1] / d;
        n[2] = -sqrt(d * d - y[0] * y[0] - y[1] * y[1]) / d;
    } else {
        n[0] = y[0]; n[1] = y[1]; n[2] = y[2];
    }
}

/* why the hybrid ball's driver stopped (contact_model = 2): bmh_interval's status (1 a step failed;
 * a Zeno sequence does not stop it: the ball is held on the wall, bmh_hold) */
typedef struct {
    int status;
    double t_from, t_to; /* the interval it could not do */
    int mode;            /* the mode it started in */
} hyb_stop;

/* the hybrid ball's chamber along the fit (translation: the kernel's BM_POLY with its position and
 * velocity terms; motion = 2: BMG_POLY, the fit's kin(t) and state(t)) */
static void hybrid_chamber(ball_in_shell *b, const fit *f)
{
    bmh_problem *H = &b->H;
    if (b->motion == 2) {
        bmg_problem *G = &H->gen;
        memcpy(G->poly, f->poly, sizeof G->poly);
        G->t0 = f->t0;
        memcpy(G->pos, f->pos, sizeof G->pos);
        memcpy(G->om, f->om, sizeof G->om);
        memcpy(G->Q, f->Q, sizeof G->Q);
    } else {
        double o[6], *q = H->roll.mp_kin;
        memcpy(H->roll.mp, f->mp, sizeof H->roll.mp);
        recon_state(f, f->mp[0], o); /* the fit's x, v at t0: a(t) is integrated from there */
        q[0] = o[0]; q[1] = o[2]; q[2] = o[1]; q[3] = o[3];
        for (int j = 0; j < 4; j++) { /* ReconstructedPlatform's p_j = a_j / ((j + 1) (j + 2)), q_j = a_j / (j + 1) */
            q[4 + j] = f->mp[1 + j] / (double)((j + 1) * (j + 2));
            q[8 + j] = f->mp[5 + j] / (double)((j + 1) * (j + 2));
            q[12 + j] = f->mp[1 + j] / (j + 1.0);
            q[16 + j] = f->mp[5 + j] / (j + 1.0);
        }
    }
}

/* contact_model = 2: the hybrid ball from *in to t_end along the fit (bmh_interval: events inside
 * the interval located and applied, the bookkeeping carried); 1 and *out, or 0 and *stop */
static int hybrid_advance(ball_in_shell *b, const ball_state *in, double t_end, const fit *f, ball_state *out,
                          hyb_stop *stop)
{
    double ring[HYB_BURST * BMH_NEV], row[BMH_NCOL];
    long long n_ev = 0;
    bm_stats st = {0, 0, 0};
    hybrid_chamber(b, f);
    *out = *in;
    out->t = t_end;
    if (!(t_end - in->t > 0.0)) return 1;
    double A[3], vA[3], aA[3], Om[3]; /* HybridBall.set_motion: the gap's resolution at the run's start */
    bmh_chamber(&b->H, in->t, A, vA, aA, Om, NULL);
    b->H.gap_res = HYB_HOP_MIN_ULPS * 2.2e-16 * (b->H.R + sqrt(bmh_dot(A, A)));
    int status = bmh_interval(&b->H, in->t, t_end, &out->mode, out->y, &out->h, out->book, ring, HYB_BURST, &n_ev,
                              row, &st);
    if (!status) return 1;
    stop->status = status;
    stop->t_from = in->t;
    stop->t_to = t_end;
    stop->mode = in->mode;
    return 0;
}

/* HybridBall.start_rolling: the hybrid state at s->t of the rolling model's start s (n, omega):
 * rolling if rolling holds there, else what the wall decides (on_wall: sliding, or flight) */
static void hybrid_start(ball_in_shell *b, ball_state *s, const fit *f)
{
    const bmh_problem *H = &b->H;
    bmh_run run = {H, 0.0, 0.0, 0.0, NAN, NAN, {0.0, 0.0}, {0.0, 0.0, 0.0}, 0, 0, NAN, NAN};
    double N, Ft, y[BMH_NZ], z[BMH_NZ], rec[BMH_NEV];
    int ny;
    hybrid_chamber(b, f);
    memcpy(y, s->y, 6 * sizeof(double));
    bmh_roll_out(H, s->t, y, &N, &Ft);
    s->mode = BMH_ROLLING;
    bmh_rolling_state(&run, y, y + 3, 0.0, 0.0, 0.0, s->y);
    if (!(N > 0.0 && Ft <= H->mu * N)) {
        bmh_free_state(&run, BMH_ROLLING, s->t, s->y, z);
        s->mode = bmh_on_wall(&run, s->t, z, s->y, &ny, rec, 0);
    }
    if (s->mode == BMH_FLIGHT && isnan(run.t_first_flight)) run.t_first_flight = s->t;
    double book[BMH_NBOOK] = {run.E_impact, run.n_impacts, run.v_impact_max, run.t_first_slip, run.t_first_flight,
                              run.Q[0], run.Q[1], run.seed[0], run.seed[1], run.seed[2], run.rebound, run.w_lost,
                              run.t_held, run.held_window};
    memcpy(s->book, book, sizeof book);
}

/* BallModel.advance along the fit's a(t): 1 and *out, or 0 when the integrator fails */
/* (motion = 2: ChamberModel.advance along the fit's kin(t), the kernel's bmg_poly_rhs; contact_model
 * = 2: hybrid_advance, the reason it stopped in *stop) */
static int advance(ball_in_shell *b, const ball_state *in, double t_end, const fit *f, ball_state *out,
                   hyb_stop *stop)
{
    if (b->contact == 2) return hybrid_advance(b, in, t_end, f, out, stop);
    const bm_problem *P = &b->P;
    bm_rhs_fn rhs = bm_ball_rhs;
    bmg_poly_ctx gctx = {b->G.c, f->poly};
    const void *ctx = NULL;
    if (b->motion == 2) {
        P = &b->G.base;
        rhs = bmg_poly_rhs;
        ctx = &gctx;
    } else {
        memcpy(b->P.mp, f->mp, sizeof b->P.mp);
        b->P.motion = BM_POLY;
    }
    *out = *in;
    out->t = t_end;
    if (!(t_end - in->t > 0.0)) return 1;
    double h = in->h;
    if (P->adaptive && !(h > 0.0 && isfinite(h))) {
        double f0[BM_NY];
        rhs(P, ctx, in->t, in->y, f0);
        if (!bm_all_finite(f0, P->ny)) return 0;
        h = bm_initial_step_np(P, rhs, ctx, in->t, in->y, f0, t_end - in->t);
    }
    bm_stats st = {0, 0, 0};
    if (!bm_advance(P, &b->T, rhs, ctx, in->t, out->y, t_end, &h, &st)) return 0;
    out->h = P->adaptive ? h : P->h_fixed;
    return 1;
}

/* the published outputs: bm_outputs' 22 (outputs.Outputs), then the contact point and the
 * force in the chamber's axes and the moment about O1 */
enum { O_XP, O_YP, O_ZP, O_XC, O_YC, O_ZC, O_WX, O_WY, O_WZ, O_N, O_FX, O_FY, O_FZ, O_MR, O_MAX, O_MAY,
       O_MAZ, O_FT, O_RATIO, O_CONTACT, O_ROLLING, O_PDISS, O_PGRIND, O_SBED, O_XPCH, O_YPCH, O_ZPCH, O_FXCH, O_FYCH, O_FZCH,
       O_MO1X, O_MO1Y, O_MO1Z,
       /* the hybrid ball's (contact_model = 1: mode 1, no slip, gap, impacts or losses, first times never) */
       O_MODE, O_SLIP, O_GAP, O_NIMP, O_VIMP, O_EFRIC, O_EIMP, O_TSLIP, O_TFLIGHT, O_VXC, O_VYC, O_VZC, N_OUT };

/* motion = 2 (ballinshell_fmu._general_outputs): from ChamberOutputs go at the chamber state cs */
static void general_outputs(const ball_in_shell *b, const double *y, const double *cs, const double *go, double *o)
{
    double R = b->R, d = b->d, nx = y[0], ny = y[1], nz = y[2];
    double ex = R * cs[17], ey = R * cs[20], ez = R * cs[23];
    double sx = go[16], sy = go[17], sz = go[18], Px = go[0], Py = go[1], Pz = go[2];
    double mo[3] = {Py * sz - Pz * sy, Pz * sx - Px * sz, Px * sy - Py * sx};
    o[O_XP] = R * nx + ex; o[O_YP] = R * ny + ey; o[O_ZP] = R * nz + ez;
    o[O_XC] = d * nx + ex; o[O_YC] = d * ny + ey; o[O_ZC] = d * nz + ez;
    o[O_WX] = go[9]; o[O_WY] = go[10]; o[O_WZ] = go[11];
    o[O_N] = go[13]; o[O_FX] = sx; o[O_FY] = sy; o[O_FZ] = sz;
    o[O_MR] = mo[2];
    o[O_MAX] = R * (ny * sz - nz * sy); o[O_MAY] = R * (nz * sx - nx * sz); o[O_MAZ] = R * (nx * sy - ny * sx);
    o[O_FT] = go[14]; o[O_RATIO] = go[15]; o[O_CONTACT] = go[26]; o[O_ROLLING] = go[27]; o[O_PDISS] = 0.0;
    o[O_PGRIND] = 0.0; o[O_SBED] = 1.0; /* lossless, no bed (bed = 0: the share is 1) */
    o[O_XPCH] = go[3]; o[O_YPCH] = go[4]; o[O_ZPCH] = go[5];
    o[O_FXCH] = go[19]; o[O_FYCH] = go[20]; o[O_FZCH] = go[21];
    o[O_MO1X] = mo[0]; o[O_MO1Y] = mo[1]; o[O_MO1Z] = mo[2];
}

/* motion = 1: the chamber does not turn, its axes are the frame's. The moment about O1 is
 * A x F + M_A, A = (x1O, y1O, R) (with losses M_A holds the material's moments too), so MO1z is
 * the crank's torque M_reaction plus MAz */
static void translation_extras(double R, double xo, double yo, double o[N_OUT])
{
    double sx = o[O_FX], sy = o[O_FY], sz = o[O_FZ];
    o[O_XPCH] = o[O_XP]; o[O_YPCH] = o[O_YP]; o[O_ZPCH] = o[O_ZP];
    o[O_FXCH] = sx; o[O_FYCH] = sy; o[O_FZCH] = sz;
    o[O_MO1X] = (yo * sz - R * sy) + o[O_MAX];
    o[O_MO1Y] = (R * sx - xo * sz) + o[O_MAY];
    o[O_MO1Z] = o[O_MR] + o[O_MAZ];
}

/* v_C [m/s] of a rolling state at t, fixed axes: v_A + R (Omega x n) + r (n x omega), v_A and Omega
 * the reconstruction's at t (motion = 1: (vx1O, vy1O, 0), Omega = 0), in this operation order
 * (ballinshell_fmu.BallInShell._centre_velocity) */
static void centre_velocity(const ball_in_shell *b, const double *y, const fit *f, double t, double vc[3])
{
    double n[3], w[3], vA[3], Om[3];
    if (b->motion == 2) {
        double cs[BMG_NCS];
        general_state(f, t, cs);
        memcpy(n, y, sizeof n);
        memcpy(w, y + 3, sizeof w);
        memcpy(vA, cs + 3, sizeof vA);
        memcpy(Om, cs + 9, sizeof Om);
    } else {
        double m[6];
        to_n(b, y, n);
        memcpy(w, y + b->P.ny - 3, sizeof w);
        recon_state(f, t, m);
        vA[0] = m[2]; vA[1] = m[3]; vA[2] = 0.0;
        Om[0] = 0.0; Om[1] = 0.0; Om[2] = 0.0;
    }
    double R = b->H.R, r = b->H.r;
    double c1[3] = {Om[1] * n[2] - Om[2] * n[1], Om[2] * n[0] - Om[0] * n[2], Om[0] * n[1] - Om[1] * n[0]};
    double c2[3] = {n[1] * w[2] - n[2] * w[1], n[2] * w[0] - n[0] * w[2], n[0] * w[1] - n[1] * w[0]};
    for (int i = 0; i < 3; i++) vc[i] = (vA[i] + R * c1[i]) + r * c2[i];
}

/* contact_model = 2, a sliding or flying ball (free state z = s->y: C, v_C, omega, W, E_friction)
 * at the chamber state cs (BMG_NCS: A, v_A, a_A, Omega, Omega', Q): n = (C - A)/|C - A|; the
 * contact point P = A + R n (in flight the wall's point nearest the ball); N and the friction
 * force Ft of the sliding ball (hybrid.HybridBall._slide_forces), 0 in flight; the ball's force on
 * the chamber F = N n - Ft at P; the moments about A (R n x F) and O1 (A x F + M_A); the rest as
 * the rolling ball's outputs mean them (ballinshell_fmu.BallInShell._free_outputs, operation for
 * operation: motion = 1 with Q = identity, O = A - (0, 0, R)) */
static void free_outputs(const ball_in_shell *b, const ball_state *s, const double *cs, double o[N_OUT])
{
    const bmh_problem *H = &b->H;
    const double *z = s->y, *A = cs, *vA = cs + 3, *aA = cs + 6, *Om = cs + 9, *Q = cs + 15;
    double R = H->R, rho[3], n[3], Ftv[3] = {0.0, 0.0, 0.0}, N = 0.0, slip = 0.0;
    for (int i = 0; i < 3; i++) rho[i] = z[i] - A[i];
    double dist = sqrt(bmh_dot(rho, rho));
    for (int i = 0; i < 3; i++) n[i] = rho[i] / dist;
    if (s->mode == BMH_SLIDING) {
        double nn[3], vW[3];
        N = bmh_slide_forces_at(H, A, vA, aA, Om, cs + 12, z, s->book + 7, Ftv, &slip, nn, vW, NULL);
    }
    double Ft = sqrt(bmh_dot(Ftv, Ftv));
    double sx = N * n[0] - Ftv[0], sy = N * n[1] - Ftv[1], sz = N * n[2] - Ftv[2];
    double e[3] = {R * Q[2], R * Q[5], R * Q[8]}; /* A - O */
    double O[3] = {A[0] - e[0], A[1] - e[1], A[2] - e[2]};
    double rn[3] = {R * n[0], R * n[1], R * n[2]};
    double MA[3] = {rn[1] * sz - rn[2] * sy, rn[2] * sx - rn[0] * sz, rn[0] * sy - rn[1] * sx};
    double MO[3] = {(A[1] * sz - A[2] * sy) + MA[0], (A[2] * sx - A[0] * sz) + MA[1], (A[0] * sy - A[1] * sx) + MA[2]};
    int contact = N > 0.0;
    o[O_XP] = rn[0] + e[0]; o[O_YP] = rn[1] + e[1]; o[O_ZP] = rn[2] + e[2];
    o[O_N] = N; o[O_FX] = sx; o[O_FY] = sy; o[O_FZ] = sz;
    o[O_MR] = b->motion == 2 ? MO[2] : O[0] * sy - O[1] * sx;
    o[O_MAX] = MA[0]; o[O_MAY] = MA[1]; o[O_MAZ] = MA[2];
    o[O_XC] = rho[0] + e[0]; o[O_YC] = rho[1] + e[1]; o[O_ZC] = rho[2] + e[2];
    o[O_WX] = z[6]; o[O_WY] = z[7]; o[O_WZ] = z[8];
    o[O_FT] = Ft; o[O_RATIO] = contact ? Ft / N : INFINITY;
    o[O_CONTACT] = contact ? 1.0 : 0.0; o[O_ROLLING] = 0.0;
    o[O_PDISS] = 0.0; o[O_PGRIND] = 0.0; o[O_SBED] = 1.0; /* lossless, no bed */
    for (int i = 0; i < 3; i++) {
        o[O_XPCH + i] = Q[i] * rn[0] + Q[3 + i] * rn[1] + Q[6 + i] * rn[2];
        o[O_FXCH + i] = Q[i] * sx + Q[3 + i] * sy + Q[6 + i] * sz;
        o[O_MO1X + i] = MO[i];
    }
    o[O_ZPCH] = o[O_ZPCH] + R;
    o[O_SLIP] = s->mode == BMH_SLIDING ? slip : 0.0;
    o[O_GAP] = s->mode == BMH_FLIGHT ? bm_pymax(H->d - dist, 0.0) : 0.0;
    o[O_VXC] = z[3]; o[O_VYC] = z[4]; o[O_VZC] = z[5];
    o[O_EFRIC] = z[10];
}

/* outputs.evaluate of a state at t, with the platform motion reconstructed at t (motion = 2:
 * turning.model.evaluate_c at the reconstructed chamber state); contact_model = 2 off rolling:
 * free_outputs at the fit's chamber state. Then the hybrid ball's outputs and v_C. */
static void outputs_at(ball_in_shell *b, const ball_state *s, const fit *f, double t, double o[N_OUT])
{
    if (b->contact == 2 && s->mode != BMH_ROLLING) {
        double cs[BMG_NCS], Om[3], Omd[3];
        if (b->motion == 2) {
            general_state(f, t, cs);
        } else {
            hybrid_chamber(b, f);
            memset(cs, 0, sizeof cs);
            bmh_chamber(&b->H, t, cs, cs + 3, cs + 6, Om, Omd);
            cs[15] = 1.0; cs[19] = 1.0; cs[23] = 1.0;
        }
        free_outputs(b, s, cs, o);
    } else if (b->motion == 2) {
        double cs[BMG_NCS], go[BMG_NOUT];
        general_state(f, t, cs);
        bmg_outputs(b->G.oc, s->y, cs, go);
        general_outputs(b, s->y, cs, go, o);
    } else {
        double m[6], nw[BM_NY];
        recon_state(f, t, m);
        to_n(b, s->y, nw);
        memcpy(nw + 3, s->y + b->P.ny - 3, 3 * sizeof(double));
        bm_outputs(&b->P, nw, m[4], m[5], m[0], m[1], o);
        translation_extras(b->R, m[0], m[1], o);
    }
    if (s->mode == BMH_ROLLING) {
        centre_velocity(b, s->y, f, t, o + O_VXC);
        o[O_SLIP] = 0.0;
        o[O_GAP] = 0.0;
        o[O_EFRIC] = b->contact == 2 ? s->book[6] : 0.0;
    }
    o[O_MODE] = s->mode;
    if (b->contact == 2) {
        o[O_NIMP] = s->book[1]; o[O_VIMP] = s->book[2]; o[O_EIMP] = s->book[0];
        o[O_TSLIP] = isnan(s->book[3]) ? NEVER : s->book[3];
        o[O_TFLIGHT] = isnan(s->book[4]) ? NEVER : s->book[4];
    } else {
        o[O_NIMP] = 0.0; o[O_VIMP] = 0.0; o[O_EIMP] = 0.0; o[O_TSLIP] = NEVER; o[O_TFLIGHT] = NEVER;
    }
}

/* contact_model = 2: K of the hybrid state s along the fit f (hybrid.HybridBall.reaction_momentum)
 * and its torque quadrature *Lq */
static double reaction_momentum(ball_in_shell *b, const ball_state *s, const fit *f, double *Lq)
{
    bmh_run run = {&b->H, 0.0, 0.0, 0.0, NAN, NAN, {0.0, 0.0}, {0.0, 0.0, 0.0}, 0, 0, NAN, NAN};
    double z[BMH_NZ];
    hybrid_chamber(b, f);
    bmh_free_state(&run, s->mode, s->t, s->y, z);
    *Lq = z[BMH_NZ - 1];
    return bmh_reaction_momentum(&b->H, s->t, z);
}

/* M_reaction_mean over the step of length h from s0 to s1 along the fit f: ((Lq1 - Lq0) - (K1 - K0)) / h
 * (contact_model = 2; ballinshell_fmu.BallInShell._torque_mean) */
static double torque_mean(ball_in_shell *b, const ball_state *s0, const ball_state *s1, const fit *f, double h)
{
    double L0, L1;
    double K0 = reaction_momentum(b, s0, f, &L0), K1 = reaction_momentum(b, s1, f, &L1);
    return ((L1 - L0) - (K1 - K0)) / h;
}

/* the ball centre's velocity vxC..vzC published with the state at t, and the force on the chamber
 * averaged over the step of length h that ends there, m (g_vec - (v_C(t) - v_C(t - h)) / h) with
 * v_C(t - h) the one published before (h = 0: the start, where the mean is the instantaneous force
 * Fx..Fz just published); M_reaction_mean = m_mean (NAN: M_reaction, at the start and with
 * contact_model = 1) */
static void publish_motion(const ball_in_shell *b, double *v, const double o[N_OUT], double h, double m_mean)
{
    static const int vr_v[3] = {VR_vxC, VR_vyC, VR_vzC}, vr_f[3] = {VR_Fx, VR_Fy, VR_Fz};
    static const int vr_mean[3] = {VR_Fx_mean, VR_Fy_mean, VR_Fz_mean};
    static const int vr_h[9] = {VR_mode, VR_slip_speed, VR_gap, VR_n_impacts, VR_v_impact_max, VR_E_friction,
                                VR_E_impact, VR_t_first_slip, VR_t_first_flight};
    double m = b->H.m, gv[3] = {0.0, 0.0, -b->H.g};
    const double *vc = o + O_VXC;
    for (int i = 0; i < 9; i++) v[vr_h[i]] = o[O_MODE + i];
    for (int i = 0; i < 3; i++) {
        v[vr_mean[i]] = h == 0.0 ? v[vr_f[i]] : m * (gv[i] - (vc[i] - v[vr_v[i]]) / h);
        v[vr_v[i]] = vc[i];
    }
    v[VR_M_reaction_mean] = isnan(m_mean) ? v[VR_M_reaction] : m_mean;
}

static void publish(double *v, const double o[N_OUT])
{
    static const int vr[] = {VR_xP, VR_yP, VR_zP, VR_xC, VR_yC, VR_zC, VR_wx, VR_wy, VR_wz, VR_N, VR_Fx,
                             VR_Fy, VR_Fz, VR_M_reaction, VR_MAx, VR_MAy, VR_MAz, VR_Ft, VR_friction_ratio};
    static const int vr_more[] = {VR_xP_ch, VR_yP_ch, VR_zP_ch, VR_Fx_ch, VR_Fy_ch, VR_Fz_ch,
                                  VR_MO1x, VR_MO1y, VR_MO1z};
    for (int i = 0; i < (int)(sizeof vr / sizeof vr[0]); i++) v[vr[i]] = vr[i] == VR_friction_ratio && isinf(o[i]) ? copysign(FMU_BIG, o[i]) : o[i];
    v[VR_contact] = o[O_CONTACT] != 0.0;
    v[VR_rolling] = o[O_ROLLING] != 0.0;
    v[VR_P_diss] = o[O_PDISS];
    v[VR_P_grind] = o[O_PGRIND];
    v[VR_s_bed] = o[O_SBED];
    for (int i = 0; i < 9; i++) v[vr_more[i]] = o[O_XPCH + i];
}

/* the inputs the published outputs were computed from: those of the last feedthrough
 * refresh since the last step, else the sample the last step (or the initialisation) took */
static const sample *published_inputs(const ball_in_shell *b)
{
    if (b->has_fed) return &b->fed;
    return b->n_samples ? &b->samples[b->n_samples - 1] : NULL;
}

/* motion = 1: the outputs on the published state with the chamber acceleration and position
 * just set; 0 (nothing to refresh) when one is not finite (the next step refuses it) or none
 * of them differs from what the published outputs were computed from (another input was set,
 * or the same values again) */
static int translation_feedthrough(const ball_in_shell *b, const double *v, double t, sample *now,
                                   double o[N_OUT])
{
    double x = v[VR_x1O], y = v[VR_y1O], ax = v[VR_ax1O], ay = v[VR_ay1O];
    if (!(isfinite(x) && isfinite(y) && isfinite(ax) && isfinite(ay))) return 0;
    const sample *s = published_inputs(b);
    int free_ball = b->contact == 2 && b->state.mode != BMH_ROLLING; /* N depends on v_A too */
    if (s && s->x == x && s->y == y && s->ax == ax && s->ay == ay &&
        (!free_ball || (s->vx == v[VR_vx1O] && s->vy == v[VR_vy1O])))
        return 0;
    const sample in = {t, x, y, v[VR_vx1O], v[VR_vy1O], ax, ay,
                       0.0, 0.0, 0.0, {0.0, 0.0, 0.0}, {0.0, 0.0, 0.0}, {0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0}};
    *now = in;
    if (free_ball) { /* the chamber of these inputs, as hybrid_chamber's */
        double cs[BMG_NCS] = {x, y, b->R, in.vx, in.vy, 0.0, ax, ay, 0.0};
        cs[15] = 1.0; cs[19] = 1.0; cs[23] = 1.0;
        free_outputs(b, &b->state, cs, o);
        return 1;
    }
    double nw[BM_NY];
    to_n(b, b->state.y, nw);
    memcpy(nw + 3, b->state.y + b->P.ny - 3, 3 * sizeof(double));
    bm_outputs(&b->P, nw, ax, ay, x, y, o);
    translation_extras(b->R, x, y, o);
    return 1;
}

/* motion = 2: the same at the chamber state of the inputs just set (A, v_A, a_A from O,
 * Omega, Omega', Q: chamber_centre); 0 when they are not a valid sample (the next step
 * refuses them) or equal, all 24, to what the published outputs were computed from */
static int general_feedthrough(const ball_in_shell *b, const double *v, double t, sample *now, double o[N_OUT])
{
    sample s;
    char why[1024];
    if (read_sample(b, v, t, &s, why, sizeof why)) return 0;
    const sample *last = published_inputs(b);
    if (last) {
        const double *was = &last->x, *is = &s.x;
        int same = 1;
        for (int i = 0; i < SAMPLE_VALUES - 1 && same; i++) same = was[i] == is[i];
        if (same) return 0;
    }
    *now = s;
    double cs[BMG_NCS], go[BMG_NOUT];
    memset(cs, 0, sizeof cs);
    chamber_centre(&s, b->R, cs, cs + 3, cs + 6);
    memcpy(cs + 9, s.om, sizeof s.om);
    memcpy(cs + 12, s.omd, sizeof s.omd);
    memcpy(cs + 15, s.q, sizeof s.q);
    if (b->contact == 2 && b->state.mode != BMH_ROLLING) {
        free_outputs(b, &b->state, cs, o);
        return 1;
    }
    bmg_outputs(b->G.oc, b->state.y, cs, go);
    general_outputs(b, b->state.y, cs, go, o);
    return 1;
}

/* direct feedthrough (interface.BALL_FEEDTHROUGH; ballinshell_fmu.BallInShell.inputs_set): the
 * force, moments and contact signals at the instance's time from the chamber motion just set,
 * on the state published at that time (input modes 1, 3, 4; with positions alone the
 * acceleration is reconstructed at the next step); left as they are if one would not be finite */
static fmi2Status inputs_set(fmu_instance *fi, void *data, double *v, double t)
{
    ball_in_shell *b = data;
    sample now;
    double o[N_OUT];
    (void)fi;
    if (b->mode == 2 || !(b->motion == 2 ? general_feedthrough(b, v, t, &now, o)
                                         : translation_feedthrough(b, v, t, &now, o)))
        return fmi2OK;
    static const int vr[] = {VR_N, VR_Fx, VR_Fy, VR_Fz, VR_M_reaction, VR_MAx, VR_MAy, VR_MAz, VR_Ft,
                             VR_Fx_ch, VR_Fy_ch, VR_Fz_ch, VR_MO1x, VR_MO1y, VR_MO1z};
    static const int oi[] = {O_N, O_FX, O_FY, O_FZ, O_MR, O_MAX, O_MAY, O_MAZ, O_FT,
                             O_FXCH, O_FYCH, O_FZCH, O_MO1X, O_MO1Y, O_MO1Z};
    for (int i = 0; i < (int)(sizeof oi / sizeof oi[0]); i++)
        if (!isfinite(o[oi[i]])) return fmi2OK;
    if (!isfinite(o[O_PDISS]) || !isfinite(o[O_PGRIND]) || isnan(o[O_RATIO])) return fmi2OK;
    for (int i = 0; i < (int)(sizeof vr / sizeof vr[0]); i++) v[vr[i]] = o[oi[i]];
    v[VR_friction_ratio] = isinf(o[O_RATIO]) ? copysign(FMU_BIG, o[O_RATIO]) : o[O_RATIO];
    v[VR_contact] = o[O_CONTACT] != 0.0;
    v[VR_rolling] = o[O_ROLLING] != 0.0;
    v[VR_P_diss] = o[O_PDISS];
    v[VR_P_grind] = o[O_PGRIND];
    b->fed = now; /* what the published outputs now come from */
    b->has_fed = 1;
    return fmi2OK;
}

/* ===================================================================== validity signals
 * the latch (Slave.invalidate): valid = false from the first loss of contact, onset of
 * slip or flagged input inconsistency, until reset; t_invalid says when */
static void invalidate(fmu_instance *fi, double *v, double t, const char *reason)
{
    if (v[VR_valid] == 0.0) return;
    v[VR_valid] = 0.0;
    v[VR_t_invalid] = t;
    fmu_log(fi, fmi2Warning, "BallInShell '%s': valid = false from t = %.9g s (latched until reset): %s",
            fmu_instance_name(fi), t, reason);
}

/* loss of contact and onset of slip, judged at communication point t with the true
 * inputs there (the published flags use extrapolated inputs) */
static void report(fmu_instance *fi, ball_in_shell *b, double *v, double t, const double o[N_OUT])
{
    char when[96], why[160];
    int was_contact = b->confirmed_contact, was_rolling = b->confirmed_rolling;
    int contact = o[O_CONTACT] != 0.0, rolling = o[O_ROLLING] != 0.0;
    b->confirmed_contact = contact;
    b->confirmed_rolling = rolling;
    if (contact && rolling) return; /* nothing to say (and formatting costs microseconds) */
    if (b->has_t_prev)
        snprintf(when, sizeof when, "between t = %.9g s and %.9g s", b->t_prev, t);
    else
        snprintf(when, sizeof when, "at t = %.9g s", t);
    if (was_contact && !contact)
        fmu_log(fi, fmi2Warning, "BallInShell '%s': contact lost %s (N = %.6g N): the ball leaves the wall and "
                "the rolling model no longer holds", fmu_instance_name(fi), when, o[O_N]);
    else if (was_rolling && contact && !rolling)
        fmu_log(fi, fmi2Warning, "BallInShell '%s': slip %s: |F_t|/N = %.4g > mu = %g; the ball would slide",
                fmu_instance_name(fi), when, o[O_RATIO], b->mu);
    if (!contact) {
        snprintf(why, sizeof why, "contact lost (N = %.6g N)", o[O_N]);
        invalidate(fi, v, t, why);
    } else if (!rolling) {
        snprintf(why, sizeof why, "slip: |F_t|/N = %.4g > mu = %g", o[O_RATIO], b->mu);
        invalidate(fi, v, t, why);
    }
}

/* ===================================================================== corrected history
 * Integrate the current fit from the corrected state at the oldest node of the window up
 * to t_now, through every sample time in it (the fit interpolates there); the states at
 * the history's sample times before the window stay (older nodes of later windows).
 * 1 when it corrected, 0 when not (corrector off, the window's oldest state unknown: the
 * predicted state ends out), -1 when the integrator failed. */
static int has_sample_at(const ball_in_shell *b, double t)
{
    for (int i = 0; i < b->n_samples; i++)
        if (b->samples[i].t == t) return 1;
    return 0;
}

static int corrected_history(ball_in_shell *b, const fit *f, double t_now, ball_state *out, int *n, hyb_stop *stop)
{
    int idx[MAX_POINTS];
    recon_nodes(b, idx);
    int first_sample = idx[0], n_window = b->n_samples - first_sample;
    double t_first = b->samples[first_sample].t;
    const ball_state *first = NULL;
    for (int i = 0; i < b->n_hist; i++)
        if (b->hist[i].t == t_first) first = &b->hist[i];
    /* a state held on the wall (bmh_hold) is not redone from one before the hold: the hold is final */
    int held = b->contact == 2 && !isnan(b->state.book[BMH_BOOK_T_HELD]);
    int corrected = b->correct && n_window >= 2 && first && !(held && isnan(first->book[BMH_BOOK_T_HELD]));
    ball_state window[MAX_SAMPLES];
    if (corrected) {
        window[0] = *first;
        for (int i = 1; i < n_window; i++)
            if (!advance(b, &window[i - 1], b->samples[first_sample + i].t, f, &window[i], stop)) return -1;
        if (fabs(window[n_window - 1].t - t_now) > 1e-9 * fmax(1.0, fabs(t_now))) corrected = 0;
    }
    *n = 0;
    double before = corrected ? t_first : b->state.t;
    for (int i = 0; i < b->n_hist; i++)
        if (has_sample_at(b, b->hist[i].t) && b->hist[i].t < before) out[(*n)++] = b->hist[i];
    if (corrected) {
        for (int i = 0; i < n_window; i++) out[(*n)++] = window[i];
        return 1;
    }
    out[(*n)++] = b->state;
    return 0;
}

/* ===================================================================== setup */
static fmi2Status init_error(fmu_instance *fi, const char *fmt, const char *detail)
{
    fmu_log(fi, fmi2Error, "BallInShell '%s': initialisation failed: %s%s", fmu_instance_name(fi), fmt, detail);
    return fmi2Error;
}

/* motion = 1 takes a horizontal translation: the inputs of motion = 2 (z1O..az1O, Omega,
 * Omega_dot, Q) are ignored, whatever a master sets them to (FMI lets it set any input, and
 * some masters set every one). The first one seen away from its default is named once, in
 * case a chamber was meant to turn (ballinshell_fmu.BallInShell._note_ignored) */
static void note_ignored(fmu_instance *fi, ball_in_shell *b, const double *v, double t)
{
    if (b->motion != 1 || b->ignored_warned) return;
    for (int i = 0; i < SAMPLE_VALUES - 7; i++) {
        const fmu_variable *var = &FMU_VARIABLES[MOTION_VR[i]];
        double x = v[MOTION_VR[i]];
        if (x == var->start) continue;
        char a[32], c[32];
        int unit = *var->unit && strcmp(var->unit, "1") != 0;
        b->ignored_warned = 1;
        fmu_log(fi, fmi2Warning, "BallInShell '%s': at t = %.9g s input %s = %s%s%s (default %s) is ignored: "
                "motion = 1 (horizontal translation) uses x1O..ay1O only, not z1O..az1O, Omega, Omega_dot or Q; "
                "set motion = 2 for a chamber that moves vertically or turns (said once)", fmu_instance_name(fi),
                t, var->name, fmu_repr(x, a), unit ? " " : "", unit ? var->unit : "", fmu_repr(var->start, c));
        return;
    }
}

static int positive(fmu_instance *fi, const char *name, double x, const char *unit, int allow_zero)
{
    char a[32], msg[160];
    if (isfinite(x) && (x > 0.0 || (allow_zero && x == 0.0))) return 1;
    snprintf(msg, sizeof msg, "%s must be %s and finite, got %s = %s %s", name,
             allow_zero ? "non-negative" : "positive", name, fmu_repr(x, a), unit);
    init_error(fi, msg, "");
    return 0;
}

/* the hybrid ball's problem (fast._hybrid_problem of the HybridBall that ballinshell_fmu.py builds):
 * rolling on the FMU's own integrator problem (P, or G's for motion = 2) without the work
 * quadrature (energy 0: the rolling numbers of contact_model = 1), sliding and flight on the same
 * method with the free state's scales; the ball's constants (also read with contact_model = 1) */
static void hybrid_setup(ball_in_shell *b, const double *v, double inertia)
{
    bmh_problem *H = &b->H;
    double r = v[VR_r], R = v[VR_R], m = v[VR_m], g = v[VR_g], mu = v[VR_mu], mu_k = v[VR_mu_k];
    memset(H, 0, sizeof *H);
    H->R = R; H->r = r; H->d = R - r; H->m = m; H->g = g; H->Ib = inertia * m * bm_sq(r); H->lam = r / (R - r);
    H->mu = mu; H->mu_k = mu_k == -1.0 ? mu : mu_k; H->e_n = v[VR_e_n]; H->v_rest = v[VR_v_rest];
    H->slip_eps = HYB_SLIP_EPS;
    H->creep_eps = v[VR_creep_eps];
    H->kt = 1.0 + 1.0 / inertia;
    H->energy = 0;
    H->scan = HYB_SCAN; H->xtol = HYB_XTOL; H->burst = HYB_BURST; H->max_rate = HYB_MAX_RATE;
    H->zeno_hold = 1; /* a Zeno sequence holds the ball on the wall (bmh_hold) and latches valid (step) */
    H->turning = b->motion == 2;
    if (H->turning) {
        H->gen = b->G;
        H->gen.kind = BMG_POLY;
        H->roll = b->G.base;
    } else {
        H->roll = b->P;
        H->roll.motion = BM_POLY_KIN;
    }
    /* the work bound of every mode: Integrator's default, not MAX_INTERNAL_STEPS: a slip at the
     * rolling limit starts a sliding phase whose friction direction the integrator resolves in
     * tiny steps (the fast start, t0 = 0.5 s: 20406 steps between 0.268 s and 0.270 s, the library's
     * run as much as the FMU's) */
    H->roll.max_steps = HYB_MAX_STEPS;
    /* HybridBall's free integrator: the scales r, sqrt(g r), sqrt(g r) / r, m g r, no projection;
     * the torque's quadrature Lq after the states of either, outside the error norm (scale m g r
     * sqrt(r / g), as hybrid.py sizes it) */
    double v_ref = sqrt(g * r), e_ref = m * g * r, l_ref = e_ref * sqrt(r / g);
    bm_problem *F = &H->free;
    *F = H->roll;
    F->form = BM_GENERIC;
    F->ny = BMH_NZ;
    F->nerr = BMH_NZ - 1;
    for (int i = 0; i < BMH_NZ; i++) {
        F->scale[i] = i < 3 ? r : i < 6 ? v_ref : i < 9 ? v_ref / r : i < BMH_NZ - 1 ? e_ref : l_ref;
        F->tols[i] = F->tol * F->scale[i];
    }
    H->roll.nerr = H->roll.ny;
    H->roll.scale[H->roll.ny] = l_ref;
    H->roll.tols[H->roll.ny] = H->roll.tol * l_ref;
    H->roll.ny += 1;
}

/* the hybrid contact's parameters (interface._BALL_RULES; ballinshell_fmu.py's _check_contact,
 * the same messages) */
static int check_contact(fmu_instance *fi, const double *v)
{
    char msg[512], a[32], c[32];
    double mu_k = v[VR_mu_k], mu = v[VR_mu];
    int contact_model = (int)v[VR_contact_model], formulation = (int)v[VR_formulation];
    if (!(mu_k == -1.0 || (0.0 <= mu_k && mu_k <= mu))) {
        snprintf(msg, sizeof msg, "parameter mu_k = %s is outside its accepted range: -1 (equal to mu) or [0, mu = "
                 "%s] (kinetic friction does not exceed static friction)", fmu_repr(mu_k, a), fmu_repr(mu, c));
        init_error(fi, msg, "");
        return 0;
    }
    if (!positive(fi, "v_rest", v[VR_v_rest], "m/s", 0)) return 0;
    if (contact_model != 2) return 1;
    if (formulation != 1) {
        snprintf(msg, sizeof msg, "contact_model = 2 needs formulation = 1 (the paper's coordinates end at the "
                 "chamber's equator; a sliding or flying ball is followed in fixed axes), got formulation = %d",
                 formulation);
        init_error(fi, msg, "");
        return 0;
    }
    if (v[VR_delta] != 0.0 || v[VR_c_drag] != 0.0) {
        snprintf(msg, sizeof msg, "contact_model = 2 models no ground-material losses off rolling: delta = %s m and "
                 "c_drag = %s N.s/m must be 0", fmu_repr(v[VR_delta], a), fmu_repr(v[VR_c_drag], c));
        init_error(fi, msg, "");
        return 0;
    }
    if ((int)v[VR_bed] != 0) {
        snprintf(msg, sizeof msg, "contact_model = 2 has no material bed: bed = %d must be 0 (the hybrid ball "
                 "models no ground-material losses)", (int)v[VR_bed]);
        init_error(fi, msg, "");
        return 0;
    }
    return 1;
}

static fmi2Status setup(fmu_instance *fi, void *data, double *v, double t)
{
    ball_in_shell *b = data;
    double r = v[VR_r], R = v[VR_R], m = v[VR_m], g = v[VR_g], mu = v[VR_mu];
    double delta = v[VR_delta], cdrag = v[VR_c_drag], inertia = 0.4;
    double h_bed = v[VR_h_bed], w_bed = v[VR_w_bed];
    int bed = (int)v[VR_bed];
    char msg[512], a[32], c[32];
    if (!positive(fi, "r", r, "m", 0) || !positive(fi, "R", R, "m", 0) || !positive(fi, "m", m, "kg", 0) ||
        !positive(fi, "g", g, "m/s2", 0) || !positive(fi, "mu", mu, "1", 0) ||
        !positive(fi, "delta", delta, "m", 1) || !positive(fi, "c_drag", cdrag, "N.s/m", 1) ||
        !positive(fi, "w_bed", w_bed, "m", 0))
        return fmi2Error;
    if (bed != 0 && bed != 1) {
        snprintf(msg, sizeof msg, "bed must be one of [0, 1] (0 = the material fills the chamber, 1 = a bed of "
                 "depth h_bed), got %d", bed);
        return init_error(fi, msg, "");
    }
    if (bed == 1 && !(h_bed >= 0.0 && h_bed <= 2.0 * R)) {
        snprintf(msg, sizeof msg, "parameter h_bed = %s m is outside its accepted range [0, 2 R = %g] m with "
                 "bed = 1 (the bed's surface lies between the chamber's lowest and highest points)",
                 fmu_repr(h_bed, a), 2.0 * R);
        return init_error(fi, msg, "");
    }
    if (!(r < R)) {
        snprintf(msg, sizeof msg, "R must be larger than r (the ball must fit in the chamber), got r = %g m, "
                 "R = %g m", r, R);
        return init_error(fi, msg, "");
    }
    if ((R - r) / R < 1e-9) {
        snprintf(msg, sizeof msg, "R - r must be at least 1e-9 R, got r = %s m, R = %s m", fmu_repr(r, a),
                 fmu_repr(R, c));
        return init_error(fi, msg, "");
    }
    int formulation = (int)v[VR_formulation], integrator = (int)v[VR_integrator], mode = (int)v[VR_input_mode];
    int motion = (int)v[VR_motion];
    if (formulation != 1 && formulation != 2) {
        snprintf(msg, sizeof msg, "formulation must be one of [1, 2] (1 = vector, 2 = paper), got %d", formulation);
        return init_error(fi, msg, "");
    }
    if (integrator < 1 || integrator > 3) {
        snprintf(msg, sizeof msg, "integrator must be one of [1, 2, 3] (1 = DOP853, 2 = RK45, 3 = RK4), got %d",
                 integrator);
        return init_error(fi, msg, "");
    }
    double tol = v[VR_tolerance], h_fixed = v[VR_h_fixed];
    if (!(isfinite(tol) && 1e-15 <= tol && tol <= 1e-1)) {
        snprintf(msg, sizeof msg, "tolerance must be within [1e-15, 0.1], got %s", fmu_repr(tol, a));
        return init_error(fi, msg, "");
    }
    if (!(isfinite(h_fixed) && h_fixed > 0.0)) {
        snprintf(msg, sizeof msg, "fixed step h_fixed must be positive and finite, got %s s", fmu_repr(h_fixed, a));
        return init_error(fi, msg, "");
    }
    /* the ball's constants (params.Ball) and the kernel's problem (fast._problem) */
    double d = R - r, lam = r / (R - r), k = 1.0 / (r * (1.0 + inertia)), I = inertia * m * (r * r);
    bm_problem *P = &b->P;
    memset(P, 0, sizeof *P);
    P->rhs_lam = lam; P->rhs_r = r; P->rhs_g = g; P->rhs_k = k;
    double loss[9] = {k, r, g, m, d, cdrag * d / m, delta, I + m * (r * r), 1e-3 * 1e-3};
    if (delta != 0.0 || cdrag != 0.0) {
        P->rhs_lossy = 1;
        memcpy(P->rhs_loss, loss, sizeof loss);
        P->out_lossy = 1;
        P->o_cd = cdrag * d;
        P->o_delta = delta;
        memcpy(P->o_loss, loss, sizeof loss);
    }
    if (bed == 1) { /* equations.bed_constants: the resistances' share at the contact point */
        double bc[3] = {R, h_bed, w_bed};
        P->o_has_bed = 1;
        memcpy(P->o_bed, bc, sizeof bc);
        if (P->rhs_lossy) {
            P->rhs_has_bed = 1;
            memcpy(P->rhs_bed, bc, sizeof bc);
        }
    }
    P->o_lam = lam; P->o_r = r; P->o_d = d; P->o_R = R; P->o_m = m; P->o_g = g; P->o_k = k; P->o_mu = mu;
    const bm_tableau *tab = &BM_TABLEAUS[integrator == 1 ? 0 : integrator == 2 ? 1 : 2];
    P->ns = tab->ns; P->order = tab->order; P->adaptive = tab->adaptive; P->has_e3 = tab->has_e3;
    memcpy(P->A, tab->A, sizeof P->A);
    memcpy(P->B, tab->B, sizeof P->B);
    memcpy(P->C, tab->C, sizeof P->C);
    memcpy(P->E, tab->E, sizeof P->E);
    memcpy(P->E3, tab->E3, sizeof P->E3);
    P->tol = tol; P->h_fixed = h_fixed; P->h_max = INFINITY; P->max_steps = MAX_INTERNAL_STEPS;
    double omega_small = sqrt(g / (1.0 + inertia) / d), w_ref = d * omega_small / r;
    /* the work bounds (docs/conformance.md): delta <= r, c_drag <= 1e4 m omega0, and RK4
     * within MAX_INTERNAL_STEPS over max_step */
    if (delta > r) {
        snprintf(msg, sizeof msg, "parameter delta = %s m is outside its accepted range [0, r = %g] m (a "
                 "rolling-resistance length beyond the ball's radius)", fmu_repr(delta, a), r);
        return init_error(fi, msg, "");
    }
    double c_max = DRAG_LIMIT * m * omega_small;
    if (cdrag > c_max) {
        snprintf(msg, sizeof msg, "parameter c_drag = %s N.s/m is outside its accepted range [0, %.6g] N.s/m "
                 "(1e4 m omega0: a viscous time constant m/c_drag below 1e-4/omega0 makes the equations too "
                 "stiff for the explicit integrators)", fmu_repr(cdrag, a), c_max);
        return init_error(fi, msg, "");
    }
    if (!check_contact(fi, v)) return fmi2Error;
    P->form = formulation == 2 ? BM_PAPER : BM_VECTOR;
    P->ny = formulation == 2 ? 5 : 6;
    P->pap_d = d;
    P->pap_margin = 0.02;
    for (int i = 0; i < P->ny; i++) {
        P->scale[i] = i < P->ny - 3 ? (formulation == 2 ? d : 1.0) : w_ref;
        P->tols[i] = tol * P->scale[i];
    }
    bm_tab_make(P, &b->T);
    /* the initial state (BallModel.initial) */
    double x0 = v[VR_xC0], y0 = v[VR_yC0], w0[3] = {v[VR_wx0], v[VR_wy0], v[VR_wz0]};
    const char *names[5] = {"xC0", "yC0", "wx0", "wy0", "wz0"};
    double vals[5] = {x0, y0, w0[0], w0[1], w0[2]};
    for (int i = 0; i < 5; i++)
        if (!isfinite(vals[i])) {
            snprintf(msg, sizeof msg, "%s must be finite, got %s = %s", names[i], names[i], fmu_repr(vals[i], a));
            return init_error(fi, msg, "");
        }
    double rho2 = x0 * x0 + y0 * y0;
    if (rho2 > d * d) {
        char e[32], f2[32];
        snprintf(msg, sizeof msg, "initial position out of reach: the ball centre lies on a sphere of radius "
                 "R - r = %.6g m, so sqrt(xC0^2 + yC0^2) must be <= %.6g m, got xC0 = %s m, yC0 = %s m (%.6g m)",
                 d, d, fmu_repr(x0, e), fmu_repr(y0, f2), sqrt(rho2));
        return init_error(fi, msg, "");
    }
    double max_step = v[VR_max_step];
    if (!(max_step >= 0.0 && isfinite(max_step))) {
        snprintf(msg, sizeof msg, "max_step must be >= 0 and finite (0 = automatic), got max_step = %s s",
                 fmu_repr(max_step, a));
        return init_error(fi, msg, "");
    }
    if (mode < 1 || mode > 4) {
        snprintf(msg, sizeof msg, "input_mode must be one of [1, 2, 3, 4] (1 = derivatives, 2 = positions, "
                 "3 = hold, 4 = accelerations), got %d", mode);
        return init_error(fi, msg, "");
    }
    if (motion == 2) { /* BallInShell._build_general */
        if (formulation != 1) {
            snprintf(msg, sizeof msg, "motion = 2 needs formulation = 1 (vector; the paper's coordinates describe "
                     "only a translating chamber's lower hemisphere), got formulation = %d", formulation);
            return init_error(fi, msg, "");
        }
        if (delta != 0.0 || cdrag != 0.0) {
            snprintf(msg, sizeof msg, "motion = 2 is lossless: delta = %s m and c_drag = %s N.s/m must be 0 (the "
                     "ground material's losses exist only with motion = 1)", fmu_repr(delta, a), fmu_repr(cdrag, c));
            return init_error(fi, msg, "");
        }
        if (bed != 0) {
            snprintf(msg, sizeof msg, "motion = 2 has no material bed: bed = %d must be 0 (the turning chamber's "
                     "model is lossless)", bed);
            return init_error(fi, msg, "");
        }
        if (mode != 1 && mode != 3) {
            snprintf(msg, sizeof msg, "input_mode = %d is not available with motion = 2: use 1 (derivatives) or "
                     "3 (hold)", mode);
            return init_error(fi, msg, "");
        }
    }
    b->motion = motion;
    if (motion == 2) { /* turning.kernel.problem's parts: the integrator (G.base) and the constants */
        bmg_problem *G = &b->G;
        memset(G, 0, sizeof *G);
        G->base = *P;
        double cg[6] = {R / d, lam, R, r, g, k};
        double og[10] = {R / d, lam, R, r, g, k, d, m, I, mu};
        memcpy(G->c, cg, sizeof cg);
        memcpy(G->oc, og, sizeof og);
    }
    b->contact = (int)v[VR_contact_model];
    hybrid_setup(b, v, inertia);
    b->max_step = max_step != 0.0 ? max_step : 0.05 * 2.0 * M_PI / omega_small;
    if (integrator == 3 && b->max_step / h_fixed > MAX_INTERNAL_STEPS) {
        snprintf(msg, sizeof msg, "parameter h_fixed = %s s is outside its accepted range [%.6g, inf) s "
                 "(max_step / %d internal steps, max_step = %.6g s)", fmu_repr(h_fixed, a),
                 b->max_step / MAX_INTERNAL_STEPS, MAX_INTERNAL_STEPS, b->max_step);
        return init_error(fi, msg, "");
    }
    b->mode = mode;
    b->points = mode == 1 || mode == 4 ? 2 : mode == 2 ? 6 : 1;
    b->a_tol = v[VR_input_tol];
    b->omega_small = omega_small;
    b->correct = v[VR_corrector] != 0.0 && mode != 3;
    b->R = R;
    b->d = d;
    b->mu = mu;
    b->z_eps = Z_HYSTERESIS * m * fmax(g, 1.0);
    double n[3] = {x0 / d, y0 / d, -sqrt(fmax(0.0, 1.0 - rho2 / (d * d)))};
    memset(&b->state, 0, sizeof b->state);
    b->state.t = t;
    b->state.mode = BMH_ROLLING;
    if (formulation == 2) { /* PaperFormulation.from_nw */
        if (n[2] > -P->pap_margin) {
            snprintf(msg, sizeof msg, "paper formulation: the ball starts at n_z = %.6g, within the margin %g of the "
                     "chamber's equator (its coordinates need n_z < -%g); use formulation 'vector'", n[2],
                     P->pap_margin, P->pap_margin);
            return init_error(fi, msg, "");
        }
        b->state.y[0] = n[0] * d; b->state.y[1] = n[1] * d;
        b->state.y[2] = w0[0]; b->state.y[3] = w0[1]; b->state.y[4] = w0[2];
    } else if (motion == 1) {
        b->state.y[0] = n[0]; b->state.y[1] = n[1]; b->state.y[2] = n[2];
        b->state.y[3] = w0[0]; b->state.y[4] = w0[1]; b->state.y[5] = w0[2];
    }
    b->state.h = NAN;
    /* restoring an FMU state: the configuration is all; the dynamic state, the inputs and the
     * outputs are the state's (the check below makes sure they fit it) */
    if (fmu_setup_kind(fi) == FMU_SETUP_RESTORE) return fmi2OK;
    b->n_samples = 0;
    b->has_fed = 0;
    b->h_next = 0.0;
    if (recon_push(b, v, t, msg, sizeof msg) < 0) return init_error(fi, msg, "");
    if (motion == 2) { /* ChamberModel.initial: (xC0, yC0) and w0 relative to the chamber, its axes */
        const double *Q = b->samples[0].q, *om = b->samples[0].om;
        for (int i = 0; i < 3; i++) {
            b->state.y[i] = Q[3 * i] * n[0] + Q[3 * i + 1] * n[1] + Q[3 * i + 2] * n[2];
            b->state.y[3 + i] = om[i] + (Q[3 * i] * w0[0] + Q[3 * i + 1] * w0[1] + Q[3 * i + 2] * w0[2]);
        }
    }
    fit f;
    recon_fit(b, &f); /* one sample: never singular */
    if (b->contact == 2) hybrid_start(b, &b->state, &f);
    b->n_hist = 1;
    b->hist[0] = b->state;
    b->has_t_prev = 0;
    b->confirmed_contact = b->confirmed_rolling = 1;
    b->warned = b->resolution_warned = b->inconsistency_warned = b->ignored_warned = 0;
    b->noise_sum = 0.0;
    b->has_a_mid = 0;
    v[VR_coupling_error] = 0.0;
    v[VR_valid] = 1.0;
    v[VR_t_invalid] = NEVER;
    double o[N_OUT];
    outputs_at(b, &b->state, &f, t, o);
    publish(v, o);
    publish_motion(b, v, o, 0.0, NAN);
    for (int i = 0; i < FMU_N_VARS; i++)
        if (FMU_VARIABLES[i].causality == FMU_OUTPUT && !isfinite(v[i])) {
            char e[6][32];
            snprintf(msg, sizeof msg, "the initial state (xC0 = %s m, yC0 = %s m, wx0 = %s, wy0 = %s, wz0 = %s "
                     "rad/s) gives non-finite outputs: output %s would be %s", fmu_repr(x0, e[0]),
                     fmu_repr(y0, e[1]), fmu_repr(w0[0], e[2]), fmu_repr(w0[1], e[3]), fmu_repr(w0[2], e[4]),
                     FMU_VARIABLES[i].name, fmu_repr(v[i], e[5]));
            return init_error(fi, msg, "");
        }
    if (fmu_setup_kind(fi) == FMU_SETUP_START) { /* the start's messages, once, at the exit of initialisation */
        note_ignored(fi, b, v, t);
        if (b->contact == 1) report(fi, b, v, t, o);
    }
    return fmi2OK;
}

/* ===================================================================== step */
static fmi2Status refuse_step(fmu_instance *fi, double t, const char *why)
{
    fmu_log(fi, fmi2Discard, "BallInShell '%s': step from t = %.9g s refused, last good state kept: %s",
            fmu_instance_name(fi), t, why);
    return fmi2Discard;
}

/* why the hybrid ball's driver stopped (ballinshell_fmu.py's message) */
static const char *hybrid_stop_text(const hyb_stop *s, char *why, size_t size)
{
    static const char *const modes[3] = {"flight", "rolling", "sliding"};
    snprintf(why, size, "the hybrid ball could not be followed from t = %.9g s in mode %s: stopped at t = %.9g s: the "
             "integrator could not reach t = %.9g s (non-finite values, step size underflow or more than %d internal "
             "steps)", s->t_from, modes[s->mode >= 0 && s->mode < 3 ? s->mode : 1], s->t_from, s->t_to, HYB_MAX_STEPS);
    return why;
}

/* contact_model = 2: the ball held on the wall from a Zeno stop (bmh_hold; its time and the burst's
 * span in the bookkeeping): what valid's latch says (ballinshell_fmu.BallInShell._held_reason) */
static const char *held_reason(const ball_state *s, char *why, size_t size)
{
    snprintf(why, size, "Zeno sequence: %d events within %.3g s before t = %.9g s, more than the allowed rate %g "
             "events/s: the ball is held on the wall from there, rolling only (as contact_model = 1 after its "
             "latch; a larger v_rest ends a bounce sequence sooner)", HYB_BURST, s->book[BMH_BOOK_HELD_WINDOW],
             s->book[BMH_BOOK_T_HELD], HYB_MAX_RATE);
    return why;
}

/* the contact directions of the predicted and the corrected state at t, p and q (coupling_error):
 * the formulation's n; with contact_model = 2, unless both roll, the ball centres C over R - r
 * (their difference times R is the contact point's; ballinshell_fmu.BallInShell._n_pair) */
static void n_pair(ball_in_shell *b, const ball_state *ps, const ball_state *qs, const fit *f, double p[3],
                   double q[3])
{
    if (ps->mode == BMH_ROLLING && qs->mode == BMH_ROLLING) {
        to_n(b, ps->y, p);
        to_n(b, qs->y, q);
        return;
    }
    const ball_state *st[2] = {ps, qs};
    double *out[2] = {p, q};
    hybrid_chamber(b, f);
    for (int k = 0; k < 2; k++) {
        bmh_run run = {&b->H, 0.0, 0.0, 0.0, NAN, NAN, {st[k]->book[5], st[k]->book[6]}, {0.0, 0.0, 0.0}, 0, 0,
                       NAN, NAN};
        double z[BMH_NZ];
        bmh_free_state(&run, st[k]->mode, st[k]->t, st[k]->y, z);
        for (int i = 0; i < 3; i++) out[k][i] = z[i] / b->H.d;
    }
}

static fmi2Status step(fmu_instance *fi, void *data, double *v, double t, double t_end)
{
    ball_in_shell *b = data;
    char why[1024], problem[1024];
    char call[160], tc[32];
    if (fmu_step_call(fi, NULL) > b->max_step * (1.0 + 1e-12)) { /* slave.Slave.do_step's limit */
        fmu_step_call(fi, call);
        fmu_log(fi, fmi2Discard, "BallInShell '%s': %s refused: communicationStepSize exceeds max_step = %.6g s, "
                "accepted range (0, %.6g] s; state kept at t = %s s (1/20 of the ball's natural period unless "
                "set, over which the platform motion cannot be extrapolated accurately; use a smaller step, or "
                "set max_step if you accept the error)", fmu_instance_name(fi), call, b->max_step, b->max_step,
                fmu_repr(t, tc));
        return fmi2Discard;
    }
    b->h_next = t_end - t; /* what the Python flavour computes (set_horizon(t_end - t)) */
    int pushed = recon_push(b, v, t, problem, sizeof problem);
    if (pushed < 0) return refuse_step(fi, t, problem);
    fit f;
    if (!recon_fit(b, &f))
        return refuse_step(fi, t, "the input samples do not determine the reconstruction (two samples at the same time?)");
    ball_state hist[MAX_SAMPLES + 1], predicted;
    int n_hist;
    hyb_stop stop = {0, 0.0, 0.0, 0};
    int corrected = corrected_history(b, &f, t, hist, &n_hist, &stop);
    if (corrected < 0) {
        if (stop.status) return refuse_step(fi, t, hybrid_stop_text(&stop, why, sizeof why));
        return refuse_step(fi, t, "the integrator failed on the corrector's interval");
    }
    const ball_state *now = &hist[n_hist - 1];
    double confirmed[N_OUT], out[N_OUT];
    outputs_at(b, now, &f, t, confirmed);
    if (!advance(b, now, t_end, &f, &predicted, &stop)) {
        if (stop.status)
            hybrid_stop_text(&stop, why, sizeof why);
        else if (b->P.form == BM_PAPER)
            snprintf(why, sizeof why, "paper formulation stopped before t = %.9g s: the ball centre came within "
                     "%g (R - r) of the chamber's equator, where its coordinates (xC, yC) become singular (or "
                     "the integrator failed). Use formulation 'vector', which is valid on the whole sphere",
                     t_end, b->P.pap_margin);
        else
            snprintf(why, sizeof why, "the integrator could not reach t = %.9g s (non-finite values, step size "
                     "underflow or more than %d internal steps)", t_end, MAX_INTERNAL_STEPS);
        return refuse_step(fi, t, why);
    }
    outputs_at(b, &predicted, &f, t_end, out);
    double m_mean = b->contact == 2 ? torque_mean(b, now, &predicted, &f, t_end - t) : NAN;
    double coupling_error = v[VR_coupling_error], noise_sum = b->noise_sum;
    if (corrected > 0) {
        /* a-posteriori estimate: predicted vs corrected contact point at t */
        double p[3], q[3];
        n_pair(b, &b->state, now, &f, p, q);
        double dx = p[0] - q[0], dy = p[1] - q[1], dz = p[2] - q[2];
        double step_error = b->R * sqrt(py_square(dx) + py_square(dy) + py_square(dz));
        /* what the corrector cannot repair (input noise, modes 2 and 4): each step's change
         * of the fitted acceleration mid-way through the previous interval kicks the swing;
         * kicks add in quadrature (ballinshell_fmu.py) */
        int idx[MAX_POINTS], nn = recon_nodes(b, idx);
        int measured = b->mode == 2 || b->mode == 4, full = nn == b->points;
        if (measured && full && b->has_a_mid && b->has_t_prev) {
            double nx, ny;
            recon_accel(&f, b->a_mid[0], &nx, &ny);
            noise_sum += (py_square(b->a_mid[1] - nx) + py_square(b->a_mid[2] - ny)) * py_square(t - b->t_prev);
        }
        double drift = b->R * (5.0 / 7.0) * sqrt(noise_sum) / (b->d * b->omega_small);
        /* positions only (mode 2): their round-off, ulp(X) for positions of magnitude X, is
         * up to GAIN_POSITIONS ulp(X) / hs^2 in the fitted acceleration (hs >= h/2, the node
         * spacing), which over the step h moves the ball's centre by (5/7) a h^2 / 2 relative
         * to the chamber: at most (R/d) (5/7) 2 GAIN_POSITIONS ulp(X) at the contact point */
        double resolution = 0.0;
        if (b->mode == 2) {
            double X = 0.0;
            for (int i = 0; i < nn; i++)
                X = fmax(X, fmax(fabs(b->samples[idx[i]].x), fabs(b->samples[idx[i]].y)));
            resolution = b->R / b->d * (5.0 / 7.0) * 2.0 * GAIN_POSITIONS * ulp(X);
        }
        coupling_error = sqrt(step_error * step_error + drift * drift + resolution * resolution);
    }
    /* the commit: nothing below fails */
    b->noise_sum = noise_sum;
    if (b->has_t_prev && b->motion == 1) { /* this fit's a mid-way through the interval it has just closed */
        double tm = 0.5 * (b->t_prev + t);
        b->a_mid[0] = tm;
        recon_accel(&f, tm, &b->a_mid[1], &b->a_mid[2]);
        b->has_a_mid = 1;
    }
    memcpy(b->hist, hist, (size_t)n_hist * sizeof(ball_state));
    b->n_hist = n_hist;
    b->state = predicted;
    b->has_fed = 0;
    publish(v, out);
    publish_motion(b, v, out, t_end - t, m_mean);
    v[VR_coupling_error] = coupling_error;
    if (coupling_error > v[VR_coupling_warn] && !b->warned) {
        b->warned = 1;
        fmu_log(fi, fmi2Warning, "BallInShell '%s': at t = %.9g s the contact point predicted over the last "
                "step was off by %.3g m (> coupling_warn = %g m): the communication step is too long for "
                "how fast the platform motion changes; outputs between communication points carry errors "
                "of that size (warned once)", fmu_instance_name(fi), t, coupling_error, v[VR_coupling_warn]);
    }
    note_ignored(fi, b, v, t);
    if (pushed > 0) {
        if (!b->inconsistency_warned) {
            b->inconsistency_warned = 1;
            fmu_log(fi, fmi2Warning, "BallInShell '%s': at t = %.9g s %s; flagged: valid = false (warned once)",
                    fmu_instance_name(fi), t, problem);
        }
        invalidate(fi, v, t, problem);
    }
    if (f.dropped && !b->resolution_warned) {
        b->resolution_warned = 1;
        fmu_log(fi, fmi2Warning, "BallInShell '%s': at t = %.9g s the positions (|x1O|, |y1O| up to %.6g m, "
                "resolution %.3g m) over a window of %.3g s would give acceleration errors above 1e-6 m/s2: the "
                "reconstruction uses the velocity and acceleration inputs there (warned once)",
                fmu_instance_name(fi), t, f.X, f.X * ldexp(1.0, -52), f.w);
    }
    if (b->contact == 2) { /* slip, flight and impacts are the model's: valid stays, unless the ball is held */
        if (!isnan(predicted.book[BMH_BOOK_T_HELD]))
            invalidate(fi, v, predicted.book[BMH_BOOK_T_HELD], held_reason(&predicted, why, sizeof why));
        b->t_prev = t;
        b->has_t_prev = 1;
        return fmi2OK;
    }
    report(fi, b, v, t, confirmed);
    if (out[O_CONTACT] == 0.0) {
        snprintf(why, sizeof why, "contact lost (N = %.6g N) at the end of the step", out[O_N]);
        invalidate(fi, v, t_end, why);
    } else if (out[O_ROLLING] == 0.0) {
        snprintf(why, sizeof why, "slip: |F_t|/N = %.4g > mu = %g at the end of the step", out[O_RATIO], b->mu);
        invalidate(fi, v, t_end, why);
    }
    b->t_prev = t;
    b->has_t_prev = 1;
    return fmi2OK;
}

/* ===================================================================== restored states */
/* why a ball state (of the instance's configuration) is not one it can continue from, or NULL:
 * its time and state finite (its mode's size), contact_model = 1 rolling, = 2 a mode with its
 * bookkeeping (finite energies and counts, first times NaN or finite, a unit seed or 0, flags) */
static const char *state_problem(const ball_in_shell *b, const ball_state *s)
{
    if (b->contact != 2) {
        if (s->mode != BMH_ROLLING) return "its contact mode is not rolling (contact_model = 1)";
    } else if (!(s->mode == BMH_FLIGHT || s->mode == BMH_ROLLING || s->mode == BMH_SLIDING)) {
        return "its contact mode is not 0 (flight), 1 (rolling) or 2 (sliding)";
    }
    int ny = s->mode != BMH_ROLLING ? BMH_NZ : b->contact == 2 ? b->H.roll.ny : b->P.ny;
    if (!(isfinite(s->t) && bm_all_finite(s->y, ny))) return "its ball state is not finite";
    if (b->contact == 2) {
        const double *k = s->book;
        if (!(bm_all_finite(k, 3) && k[0] >= 0.0 && k[1] >= 0.0 && k[1] == floor(k[1]) && k[2] >= 0.0 &&
              !isinf(k[3]) && !isinf(k[4]) && bm_all_finite(k + 5, 5) && (k[10] == 0.0 || k[10] == 1.0) &&
              (k[11] == 0.0 || k[11] == 1.0) && !isinf(k[BMH_BOOK_T_HELD]) && !isinf(k[BMH_BOOK_HELD_WINDOW]) &&
              isnan(k[BMH_BOOK_T_HELD]) == isnan(k[BMH_BOOK_HELD_WINDOW])))
            return "its hybrid bookkeeping (impacts, losses, first times, seed, flags, hold) is not valid";
    }
    if (s->mode == BMH_ROLLING && b->P.form == BM_VECTOR) {
        double n2 = s->y[0] * s->y[0] + s->y[1] * s->y[1] + s->y[2] * s->y[2];
        if (!(fabs(n2 - 1.0) < 1e-9)) return "its contact direction n is not a unit vector";
    }
    if (s->mode == BMH_ROLLING && b->P.form == BM_PAPER && !(b->d * b->d - s->y[0] * s->y[0] - s->y[1] * s->y[1] > 0.0))
        return "its ball centre lies at or beyond the chamber's equator";
    return NULL;
}

static fmi2Status check(fmu_instance *fi, const void *data, const double *v)
{
    const ball_in_shell *b = data;
    const char *why = NULL;
    if (!(b->n_samples >= 1 && b->n_samples <= b->points + HISTORY_EXTRA))
        why = "its input history has a wrong number of samples";
    else if (!(b->n_hist >= 1 && b->n_hist <= MAX_SAMPLES + 1)) why = "its corrector history has a wrong length";
    else if (!(b->noise_sum >= 0.0 && isfinite(b->noise_sum) && isfinite(b->h_next)))
        why = "its coupling-error sums are not finite";
    else if (b->has_a_mid && !bm_all_finite(b->a_mid, 3)) why = "its mid-interval acceleration is not finite";
    else if (!(b->has_fed == 0 || (b->has_fed == 1 && bm_all_finite(&b->fed.t, SAMPLE_VALUES))))
        why = "its feedthrough inputs are not finite";
    else if (!(v[VR_valid] == 0.0 || v[VR_valid] == 1.0) || !isfinite(v[VR_t_invalid]))
        why = "its validity latch is not a Boolean and a finite time";
    else why = state_problem(b, &b->state);
    for (int i = 0; !why && i < b->n_samples; i++) {
        const double *s = &b->samples[i].t;
        for (int j = 0; j < SAMPLE_VALUES; j++)
            if (!isfinite(s[j])) why = "an input sample is not finite";
        if (i && !(b->samples[i].t > b->samples[i - 1].t)) why = "its input samples are not in time order";
    }
    /* a step pushes the sample at its start and ends later; only the one sample of
     * initialisation is at the instance's time */
    if (!why && b->n_samples > 1 && !(b->samples[b->n_samples - 1].t < b->state.t))
        why = "its newest input sample is not before its time (only a history of one sample may end there)";
    for (int i = 0; !why && i < b->n_hist; i++)
        if (state_problem(b, &b->hist[i])) why = "a corrected state is not one it can continue from";
    if (!why) return fmi2OK;
    fmu_log(fi, fmi2Error, "BallInShell '%s': FMU state refused: %s", fmu_instance_name(fi), why);
    return fmi2Error;
}

/* ===================================================================== Model Exchange
 * The importer integrates the vector formulation's state (n, omega), stored in v at the
 * state variables n_x .. w_z (interface.ModelExchange), along the platform motion it sets:
 * ax1O, ay1O (and x1O, y1O for the moment arm) read as they are at every call (no input
 * reconstruction: input_mode 1 or 4). The derivatives are the kernel's (bm_derivative), the
 * outputs bm_outputs' at that instant; the event indicators N (loss of contact) and
 * mu N - Ft (onset of slip) cross 0 where co-simulation's report() would flag them, and the
 * event update runs report() itself: the validity latch (valid, t_invalid) as in
 * co-simulation, at the event's time.
 * Hysteresis (as the FMI standard recommends for event indicators): each indicator is shifted
 * by z_eps (1e-10 of the ball's weight) towards the side report() last judged (confirmed_contact,
 * confirmed_rolling): it crosses 0 only z_eps past the physical boundary, and after the event
 * update, which flips the judgement, it is about -2 z_eps, so an importer that restarts exactly
 * at the root it located does not meet the same crossing again. The event time moves by
 * z_eps / |dz/dt| (5e-11 s for the default ball's slip). */
static const int ME_STATES[6] = {VR_n_x, VR_n_y, VR_n_z, VR_w_x, VR_w_y, VR_w_z};

static fmi2Status me_start(fmu_instance *fi, void *data, double *v, double t)
{
    ball_in_shell *b = data;
    char msg[1024];
    (void)t;
    if (b->P.form != BM_VECTOR || b->motion != 1 || (b->mode != 1 && b->mode != 4) || b->contact != 1) {
        /* each unsupported parameter with its value and what is supported */
        size_t n = 0;
        if (b->P.form != BM_VECTOR)
            n += (size_t)snprintf(msg + n, sizeof msg - n, "formulation = 2 (supported: formulation = 1, the vector "
                                  "formulation); ");
        if (b->motion != 1)
            n += (size_t)snprintf(msg + n, sizeof msg - n, "motion = %d (supported: motion = 1, a translating "
                                  "chamber; a chamber that moves in 3-D and turns is co-simulation only); ", b->motion);
        if (b->contact != 1 && n < sizeof msg)
            n += (size_t)snprintf(msg + n, sizeof msg - n, "contact_model = %d (supported: contact_model = 1, "
                                  "rolling only: Model Exchange's states are the rolling ball's n, omega; the hybrid "
                                  "ball's switches are located inside co-simulation steps); ", b->contact);
        if (b->mode != 1 && b->mode != 4 && n < sizeof msg)
            n += (size_t)snprintf(msg + n, sizeof msg - n, "input_mode = %d (supported: input_mode = 1 or 4, the "
                                  "accelerations as set; %s); ", b->mode,
                                  b->mode == 2 ? "2 differentiates the positions by a fit over the communication points"
                                               : "3 holds the inputs over a communication step");
        if (n < sizeof msg)
            snprintf(msg + n, sizeof msg - n, "Model Exchange integrates the vector formulation of a translating "
                     "chamber from the acceleration inputs as set; run this configuration through co-simulation");
        if (fmu_is_me(fi)) return init_error(fi, msg, "");
        /* co-simulation reads its Model Exchange variables (n_x .. w_z, their derivatives,
         * z_contact, z_rolling) through this check: they exist where Model Exchange does */
        fmu_log(fi, fmi2Error, "BallInShell '%s': the Model Exchange variables (n_x .. w_z, der(n_x) .. "
                "der(w_z), z_contact, z_rolling) exist only in the configurations Model Exchange runs: %s",
                fmu_instance_name(fi), msg);
        return fmi2Error;
    }
    for (int i = 0; i < 6; i++) v[ME_STATES[i]] = b->state.y[i];
    return fmi2OK;
}

/* the outputs at t from the states and inputs in v (0), or 1 after fmu_log named the unusable input */
static int me_outputs(fmu_instance *fi, ball_in_shell *b, const double *v, double t, double y[6], double o[N_OUT])
{
    static const int in_vr[4] = {VR_x1O, VR_y1O, VR_ax1O, VR_ay1O};
    for (int i = 0; i < 4; i++)
        if (!isfinite(v[in_vr[i]])) {
            char a[32], c[32];
            fmu_log(fi, fmi2Error, "BallInShell '%s': input %s = %s refused at t = %s s: it must be finite",
                    fmu_instance_name(fi), FMU_VARIABLES[in_vr[i]].name, fmu_repr(v[in_vr[i]], a), fmu_repr(t, c));
            return 1;
        }
    for (int i = 0; i < 6; i++) y[i] = v[ME_STATES[i]];
    bm_outputs(&b->P, y, v[VR_ax1O], v[VR_ay1O], v[VR_x1O], v[VR_y1O], o);
    translation_extras(b->R, v[VR_x1O], v[VR_y1O], o);
    return 0;
}

static fmi2Status me_eval(fmu_instance *fi, void *data, double *v, double t, double *z)
{
    ball_in_shell *b = data;
    static const int der_vr[6] = {VR_der_n_x, VR_der_n_y, VR_der_n_z, VR_der_w_x, VR_der_w_y, VR_der_w_z};
    double y[6], f[6], o[N_OUT];
    if (me_outputs(fi, b, v, t, y, o)) return fmi2Error;
    bm_derivative(&b->P, y, v[VR_ax1O], v[VR_ay1O], f);
    for (int i = 0; i < 6; i++) v[der_vr[i]] = f[i];
    publish(v, o);
    if (z) { /* with hysteresis: on the side of the last event (report()'s judgement), shifted by z_eps */
        z[0] = o[O_N] + (b->confirmed_contact ? b->z_eps : -b->z_eps);
        z[1] = b->mu * o[O_N] - o[O_FT] + (b->confirmed_rolling ? b->z_eps : -b->z_eps);
    }
    return fmi2OK;
}

static fmi2Status me_event(fmu_instance *fi, void *data, double *v, double t, fmu_event *ev)
{
    ball_in_shell *b = data;
    double y[6], o[N_OUT];
    (void)ev; /* no time events; the states are never re-initialised */
    if (me_outputs(fi, b, v, t, y, o)) return fmi2Error;
    b->has_t_prev = 0; /* report() says "at t": the importer located the event */
    report(fi, b, v, t, o);
    return fmi2OK;
}

static const fmu_me ME = {
    FMU_N_STATES, FMU_N_INDICATORS, FMU_STATE_VRS, FMU_DERIVATIVE_VRS, FMU_STATE_NOMINALS, FMU_INDICATOR_VRS,
    me_start, me_eval, me_event, NULL,
};

const fmu_model FMU_MODEL = {
    FMU_IDENTIFIER, FMU_GUID, FMU_N_VARS, FMU_VARIABLES,
    sizeof(ball_in_shell), offsetof(ball_in_shell, state),
    setup, step, check, inputs_set, &ME,
};
