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
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmu_model.h"
#include "BallInShell_interface.h"
#include "bm_tableaus.h"
#include "_kernel.c"

#define MAX_SAMPLES 6 /* the largest input window (positions only) */

typedef struct {
    double t, x, y, vx, vy, ax, ay;
} sample;

typedef struct {
    double t;
    double y[BM_NY];
    double h; /* next internal step of the adaptive methods; NAN: choose one */
} ball_state;

/* the reconstructed platform motion over the coming step (InputReconstruction's fit) */
typedef struct {
    double t0, hs;
    int n;                       /* coefficients of x(tau), y(tau) */
    double cx[3 * 2], cy[3 * 2]; /* in tau = (t - t0) / hs */
    double mp[BM_NMP];           /* a(t) as the kernel's BM_POLY cubic: t0, x0..x3, y0..y3 */
} fit;

typedef struct {
    /* configuration: built by setup from the parameters */
    bm_problem P;
    bm_tab T;
    int mode, points, correct;
    double max_step, R, d, mu, coupling_warn;
    /* dynamic state: what FMU states carry */
    ball_state state; /* the predicted state at the instance's time */
    int n_samples;
    sample samples[MAX_SAMPLES];
    int n_hist;
    ball_state hist[MAX_SAMPLES]; /* corrected states at the sample times */
    int has_t_prev;
    double t_prev;
    int confirmed_contact, confirmed_rolling;
    int warned;
} ball_in_shell;

static const char *const INPUT_NAMES[6] = {"x1O", "y1O", "vx1O", "vy1O", "ax1O", "ay1O"};

/* ===================================================================== input reconstruction
 * platform.InputReconstruction: the samples of the window, the polynomial fit through
 * them (a confluent Vandermonde system in tau), a(t) and the motion's state at t. */

/* push the inputs seen at t; a second sample at the same t replaces the first.
 * NULL, or why the sample is refused (state unchanged) */
static const char *recon_push(ball_in_shell *b, const double *v, double t, char *why, size_t size)
{
    sample s = {t, v[VR_x1O], v[VR_y1O], v[VR_vx1O], v[VR_vy1O], v[VR_ax1O], v[VR_ay1O]};
    const double *vals = &s.x;
    char a[32], c[32];
    for (int i = 0; i < 6; i++)
        if (!isfinite(vals[i])) {
            snprintf(why, size, "input %s must be finite, got %s at t = %s s", INPUT_NAMES[i],
                     fmu_repr(vals[i], a), fmu_repr(t, c));
            return why;
        }
    if (b->n_samples && t < b->samples[b->n_samples - 1].t) {
        snprintf(why, size, "inputs must come in time order: got t = %s s after t = %s s", fmu_repr(t, a),
                 fmu_repr(b->samples[b->n_samples - 1].t, c));
        return why;
    }
    if (b->n_samples && t == b->samples[b->n_samples - 1].t) {
        b->samples[b->n_samples - 1] = s;
    } else {
        if (b->n_samples == b->points) {
            memmove(b->samples, b->samples + 1, (size_t)(b->n_samples - 1) * sizeof(sample));
            b->n_samples--;
        }
        b->samples[b->n_samples++] = s;
    }
    return NULL;
}

/* the inverse of M (n <= 6), correctly rounded to doubles as the Python path computes it
 * exactly in rationals: Gauss-Jordan with partial pivoting in extended precision (long
 * double: 64-bit mantissas on x86-64), rounded at the end. 0 when M is singular. */
static int invert(int n, const double M[6][6], double inv[6][6])
{
    long double A[6][12];
    for (int i = 0; i < n; i++)
        for (int j = 0; j < 2 * n; j++) A[i][j] = j < n ? (long double)M[i][j] : (long double)(j - n == i);
    for (int col = 0; col < n; col++) {
        int piv = col;
        for (int i = col + 1; i < n; i++)
            if (fabsl(A[i][col]) > fabsl(A[piv][col])) piv = i;
        if (A[piv][col] == 0.0L) return 0;
        for (int j = 0; j < 2 * n; j++) {
            long double tmp = A[col][j]; A[col][j] = A[piv][j]; A[piv][j] = tmp;
        }
        long double p = A[col][col];
        for (int j = 0; j < 2 * n; j++) A[col][j] /= p;
        for (int i = 0; i < n; i++) {
            long double f = A[i][col];
            if (i == col || f == 0.0L) continue;
            for (int j = 0; j < 2 * n; j++) A[i][j] -= f * A[col][j];
        }
    }
    for (int i = 0; i < n; i++)
        for (int j = 0; j < n; j++) inv[i][j] = (double)A[i][n + j];
    return 1;
}

/* Python's round(x, 12): the exact binary value rounded to 12 decimals (printf rounds
 * exactly, half to even), read back correctly rounded */
static double round12(double x)
{
    char buf[64];
    if (x == floor(x)) return x; /* whole numbers (equal steps): already rounded */
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

/* j (j-1) ... (j-der+1): math.perm(j, der) */
static double perm(int j, int der)
{
    double p = 1.0;
    for (int q = 0; q < der; q++) p *= (double)(j - q);
    return p;
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

static int recon_fit(const ball_in_shell *b, fit *f)
{
    const sample *s = b->samples;
    int ns = b->n_samples;
    double tk = s[ns - 1].t;
    f->t0 = tk;
    f->hs = ns > 1 ? tk - s[ns - 2].t : 1.0;
    if (b->mode == 3) { /* hold: x + v tau + a/2 tau^2 */
        f->hs = 1.0;
        f->n = 3;
        f->cx[0] = s[ns - 1].x; f->cx[1] = s[ns - 1].vx; f->cx[2] = 0.5 * s[ns - 1].ax;
        f->cy[0] = s[ns - 1].y; f->cy[1] = s[ns - 1].vy; f->cy[2] = 0.5 * s[ns - 1].ay;
    } else {
        double M[6][6] = {{0}}, inv[6][6], bx[6], by[6], hs = f->hs;
        int deriv_inputs = b->mode == 1, n = 0;
        for (int i = 0; i < ns; i++) {
            double tau = round12((s[i].t - tk) / hs);
            int orders = deriv_inputs ? 3 : 1;
            for (int der = 0; der < orders; der++, n++) {
                for (int j = der; j < (deriv_inputs ? 3 * ns : ns); j++)
                    M[n][j] = perm(j, der) * pow(tau, (double)(j - der));
            }
            if (deriv_inputs) {
                bx[n - 3] = s[i].x; bx[n - 2] = s[i].vx * hs; bx[n - 1] = s[i].ax * hs * hs;
                by[n - 3] = s[i].y; by[n - 2] = s[i].vy * hs; by[n - 1] = s[i].ay * hs * hs;
            } else {
                bx[n - 1] = s[i].x;
                by[n - 1] = s[i].y;
            }
        }
        if (!invert(n, M, inv)) return 0;
        f->n = n;
        for (int i = 0; i < n; i++) {
            f->cx[i] = dot_lr(inv[i], bx, n);
            f->cy[i] = dot_lr(inv[i], by, n);
        }
    }
    /* a(t) in physical time: the second derivative's coefficients over hs^(j+2) */
    double dx[6], dy[6], ddx[6], ddy[6];
    int n1 = deriv(f->cx, f->n, dx), n2 = deriv(dx, n1, ddx);
    deriv(f->cy, f->n, dy);
    deriv(dy, n1, ddy);
    f->mp[0] = f->t0;
    for (int j = 0; j < 4; j++) {
        f->mp[1 + j] = j < n2 ? ddx[j] / pow(f->hs, (double)(j + 2)) : 0.0;
        f->mp[5 + j] = j < n2 ? ddy[j] / pow(f->hs, (double)(j + 2)) : 0.0;
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

/* Integrator.initial_step, with numpy's order of summation in np.mean (first element,
 * then the sum of the rest) */
static double mean(const double *a, int n)
{
    double rest = 0.0;
    for (int i = 1; i < n; i++) rest += a[i];
    return (a[0] + rest) / n;
}

static double initial_step(const bm_problem *P, double t, const double *y, const double *f0, double span)
{
    double sc[BM_NY], q[BM_NY], y1[BM_NY] = {0}, f1[BM_NY];
    int ny = P->ny;
    for (int i = 0; i < ny; i++) sc[i] = P->tol * bm_pymax(fabs(y[i]), P->scale[i]) + P->tols[i];
    for (int i = 0; i < ny; i++) q[i] = (y[i] / sc[i]) * (y[i] / sc[i]);
    double d0 = sqrt(mean(q, ny));
    for (int i = 0; i < ny; i++) q[i] = (f0[i] / sc[i]) * (f0[i] / sc[i]);
    double d1 = sqrt(mean(q, ny));
    double h0 = (d0 < 1e-5 || d1 < 1e-5) ? 1e-6 : 0.01 * d0 / d1;
    h0 = bm_pymin(h0, span);
    for (int i = 0; i < ny; i++) y1[i] = y[i] + h0 * f0[i];
    bm_rhs(P, t + h0, y1, f1);
    for (int i = 0; i < ny; i++) q[i] = ((f1[i] - f0[i]) / sc[i]) * ((f1[i] - f0[i]) / sc[i]);
    double d2 = sqrt(mean(q, ny)) / h0;
    double h1 = (d1 <= 1e-15 && d2 <= 1e-15) ? bm_pymax(1e-6, h0 * 1e-3)
                                             : pow(0.01 / bm_pymax(d1, d2), 1.0 / P->order);
    return bm_pymin(bm_pymin(100 * h0, h1), P->h_max);
}

/* BallModel.advance along the fit's a(t): 1 and *out, or 0 when the integrator fails */
static int advance(ball_in_shell *b, const ball_state *in, double t_end, const fit *f, ball_state *out)
{
    bm_problem *P = &b->P;
    memcpy(P->mp, f->mp, sizeof P->mp);
    P->motion = BM_POLY;
    *out = *in;
    out->t = t_end;
    if (!(t_end - in->t > 0.0)) return 1;
    double h = in->h;
    if (P->adaptive && !(h > 0.0 && isfinite(h))) {
        double f0[BM_NY];
        bm_rhs(P, in->t, in->y, f0);
        if (!bm_all_finite(f0, P->ny)) return 0;
        h = initial_step(P, in->t, in->y, f0, t_end - in->t);
    }
    bm_stats st = {0, 0, 0};
    if (!bm_advance(P, &b->T, bm_ball_rhs, NULL, in->t, out->y, t_end, &h, &st)) return 0;
    out->h = P->adaptive ? h : P->h_fixed;
    return 1;
}

/* outputs.evaluate of a state at t, with the platform motion reconstructed at t */
static void outputs_at(ball_in_shell *b, const ball_state *s, const fit *f, double t, double o[BM_NOUT])
{
    double m[6], nw[BM_NY];
    recon_state(f, t, m);
    to_n(b, s->y, nw);
    memcpy(nw + 3, s->y + b->P.ny - 3, 3 * sizeof(double));
    bm_outputs(&b->P, nw, m[4], m[5], m[0], m[1], o);
}

enum { O_XP, O_YP, O_ZP, O_XC, O_YC, O_ZC, O_WX, O_WY, O_WZ, O_N, O_FX, O_FY, O_FZ, O_MR, O_MAX, O_MAY,
       O_MAZ, O_FT, O_RATIO, O_CONTACT, O_ROLLING, O_PDISS };

static void publish(double *v, const double o[BM_NOUT])
{
    static const int vr[] = {VR_xP, VR_yP, VR_zP, VR_xC, VR_yC, VR_zC, VR_wx, VR_wy, VR_wz, VR_N, VR_Fx,
                             VR_Fy, VR_Fz, VR_M_reaction, VR_MAx, VR_MAy, VR_MAz, VR_Ft, VR_friction_ratio};
    for (int i = 0; i < (int)(sizeof vr / sizeof vr[0]); i++) v[vr[i]] = isfinite(o[i]) ? o[i] : FMU_BIG;
    v[VR_contact] = o[O_CONTACT] != 0.0;
    v[VR_rolling] = o[O_ROLLING] != 0.0;
    v[VR_P_diss] = o[O_PDISS];
}

/* ===================================================================== validity signals
 * loss of contact and onset of slip, judged at communication point t with the true
 * inputs there (the published flags use extrapolated inputs) */
static void report(fmu_instance *fi, ball_in_shell *b, double t, const double o[BM_NOUT])
{
    char when[96];
    int was_contact = b->confirmed_contact, was_rolling = b->confirmed_rolling;
    int contact = o[O_CONTACT] != 0.0, rolling = o[O_ROLLING] != 0.0;
    b->confirmed_contact = contact;
    b->confirmed_rolling = rolling;
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
}

/* ===================================================================== corrected history
 * Integrate the current fit from the corrected state at the oldest sample of the window
 * up to t_now, through every sample time (the fit interpolates there). 1 and the states
 * in out[0..*n-1] when it corrected; 0 when there is nothing to correct (corrector off,
 * the oldest state unknown: out[0] is then the predicted state); -1 when the integrator
 * failed. */
static int corrected_history(ball_in_shell *b, const fit *f, double t_now, ball_state *out, int *n)
{
    const ball_state *first = NULL;
    *n = 1;
    out[0] = b->state;
    if (!b->correct) return 0;
    for (int i = 0; i < b->n_hist; i++)
        if (b->hist[i].t == b->samples[0].t) first = &b->hist[i];
    if (!first) return 0;
    out[0] = *first;
    for (int i = 1; i < b->n_samples; i++) {
        if (!advance(b, &out[i - 1], b->samples[i].t, f, &out[i])) return -1;
        (*n)++;
    }
    if (fabs(out[*n - 1].t - t_now) > 1e-9 * fmax(1.0, fabs(t_now))) { /* the window ends at t_now */
        *n = 1;
        out[0] = b->state;
        return 0;
    }
    return *n > 1;
}

/* ===================================================================== setup */
static fmi2Status init_error(fmu_instance *fi, const char *fmt, const char *detail)
{
    fmu_log(fi, fmi2Error, "BallInShell '%s': initialisation failed: %s%s", fmu_instance_name(fi), fmt, detail);
    return fmi2Error;
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

static fmi2Status setup(fmu_instance *fi, void *data, double *v, double t)
{
    ball_in_shell *b = data;
    double r = v[VR_r], R = v[VR_R], m = v[VR_m], g = v[VR_g], mu = v[VR_mu];
    double delta = v[VR_delta], cdrag = v[VR_c_drag], inertia = 0.4;
    char msg[512], a[32], c[32];
    if (!positive(fi, "r", r, "m", 0) || !positive(fi, "R", R, "m", 0) || !positive(fi, "m", m, "kg", 0) ||
        !positive(fi, "g", g, "m/s2", 0) || !positive(fi, "mu", mu, "1", 0) ||
        !positive(fi, "delta", delta, "m", 1) || !positive(fi, "c_drag", cdrag, "N.s/m", 1))
        return fmi2Error;
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
    P->o_lam = lam; P->o_r = r; P->o_d = d; P->o_R = R; P->o_m = m; P->o_g = g; P->o_k = k; P->o_mu = mu;
    const bm_tableau *tab = &BM_TABLEAUS[integrator == 1 ? 0 : integrator == 2 ? 1 : 2];
    P->ns = tab->ns; P->order = tab->order; P->adaptive = tab->adaptive; P->has_e3 = tab->has_e3;
    memcpy(P->A, tab->A, sizeof P->A);
    memcpy(P->B, tab->B, sizeof P->B);
    memcpy(P->C, tab->C, sizeof P->C);
    memcpy(P->E, tab->E, sizeof P->E);
    memcpy(P->E3, tab->E3, sizeof P->E3);
    P->tol = tol; P->h_fixed = h_fixed; P->h_max = INFINITY; P->max_steps = 1000000;
    double omega_small = sqrt(g / (1.0 + inertia) / d), w_ref = d * omega_small / r;
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
    if (mode < 1 || mode > 3) {
        snprintf(msg, sizeof msg, "input_mode must be one of [1, 2, 3] (1 = derivatives, 2 = positions, "
                 "3 = hold), got %d", mode);
        return init_error(fi, msg, "");
    }
    b->max_step = max_step != 0.0 ? max_step : 0.05 * 2.0 * M_PI / omega_small;
    b->mode = mode;
    b->points = mode == 1 ? 2 : mode == 2 ? 6 : 1;
    b->correct = v[VR_corrector] != 0.0 && mode != 3;
    b->R = R;
    b->d = d;
    b->mu = mu;
    b->coupling_warn = v[VR_coupling_warn];
    double n[3] = {x0 / d, y0 / d, -sqrt(fmax(0.0, 1.0 - rho2 / (d * d)))};
    memset(&b->state, 0, sizeof b->state);
    b->state.t = t;
    if (formulation == 2) { /* PaperFormulation.from_nw */
        if (n[2] > -P->pap_margin) {
            snprintf(msg, sizeof msg, "paper formulation: the ball starts at n_z = %.6g, within the margin %g of the "
                     "chamber's equator (its coordinates need n_z < -%g); use formulation 'vector'", n[2],
                     P->pap_margin, P->pap_margin);
            return init_error(fi, msg, "");
        }
        b->state.y[0] = n[0] * d; b->state.y[1] = n[1] * d;
        b->state.y[2] = w0[0]; b->state.y[3] = w0[1]; b->state.y[4] = w0[2];
    } else {
        b->state.y[0] = n[0]; b->state.y[1] = n[1]; b->state.y[2] = n[2];
        b->state.y[3] = w0[0]; b->state.y[4] = w0[1]; b->state.y[5] = w0[2];
    }
    b->state.h = NAN;
    b->n_samples = 0;
    if (recon_push(b, v, t, msg, sizeof msg)) return init_error(fi, msg, "");
    b->n_hist = 1;
    b->hist[0] = b->state;
    b->has_t_prev = 0;
    b->confirmed_contact = b->confirmed_rolling = 1;
    b->warned = 0;
    v[VR_coupling_error] = 0.0;
    fit f;
    double o[BM_NOUT];
    recon_fit(b, &f); /* one sample: never singular */
    outputs_at(b, &b->state, &f, t, o);
    publish(v, o);
    report(fi, b, t, o);
    return fmi2OK;
}

/* ===================================================================== step */
static fmi2Status refuse_step(fmu_instance *fi, double t, const char *why)
{
    fmu_log(fi, fmi2Discard, "BallInShell '%s': step from t = %.9g s refused, last good state kept: %s",
            fmu_instance_name(fi), t, why);
    return fmi2Discard;
}

static fmi2Status step(fmu_instance *fi, void *data, double *v, double t, double h)
{
    ball_in_shell *b = data;
    char why[512];
    double t_end = t + h;
    if (h > b->max_step * (1.0 + 1e-12)) {
        fmu_log(fi, fmi2Discard, "BallInShell '%s': communication step %g s refused: it exceeds max_step = %.4g s "
                "(1/20 of the ball's natural period unless set), over which the platform motion cannot be "
                "extrapolated accurately; use a smaller step, or set max_step if you accept the error",
                fmu_instance_name(fi), h, b->max_step);
        return fmi2Discard;
    }
    if (recon_push(b, v, t, why, sizeof why)) return refuse_step(fi, t, why);
    fit f;
    if (!recon_fit(b, &f))
        return refuse_step(fi, t, "the input samples do not determine the reconstruction (two samples at the same time?)");
    ball_state hist[MAX_SAMPLES], predicted;
    int n_hist;
    int corrected = corrected_history(b, &f, t, hist, &n_hist);
    if (corrected < 0) return refuse_step(fi, t, "the integrator failed on the corrector's interval");
    const ball_state *now = &hist[n_hist - 1];
    double confirmed[BM_NOUT], out[BM_NOUT];
    outputs_at(b, now, &f, t, confirmed);
    if (!advance(b, now, t_end, &f, &predicted)) {
        if (b->P.form == BM_PAPER)
            snprintf(why, sizeof why, "paper formulation stopped before t = %.9g s: the ball centre came within "
                     "%g (R - r) of the chamber's equator, where its coordinates (xC, yC) become singular (or "
                     "the integrator failed). Use formulation 'vector', which is valid on the whole sphere",
                     t_end, b->P.pap_margin);
        else
            snprintf(why, sizeof why, "the integrator could not reach t = %.9g s (non-finite values, step size "
                     "underflow or more than 1000000 internal steps)", t_end);
        return refuse_step(fi, t, why);
    }
    outputs_at(b, &predicted, &f, t_end, out);
    if (corrected > 0) { /* a-posteriori estimate: predicted vs corrected contact point at t */
        double p[3], q[3];
        to_n(b, b->state.y, p);
        to_n(b, now->y, q);
        double dx = p[0] - q[0], dy = p[1] - q[1], dz = p[2] - q[2];
        v[VR_coupling_error] = b->R * sqrt(py_square(dx) + py_square(dy) + py_square(dz));
        if (v[VR_coupling_error] > b->coupling_warn && !b->warned) {
            b->warned = 1;
            fmu_log(fi, fmi2Warning, "BallInShell '%s': at t = %.9g s the contact point predicted over the last "
                    "step was off by %.3g m (> coupling_warn = %g m): the communication step is too long for "
                    "how fast the platform motion changes; outputs between communication points carry errors "
                    "of that size (warned once)", fmu_instance_name(fi), t, v[VR_coupling_error], b->coupling_warn);
        }
    }
    memcpy(b->hist, hist, (size_t)n_hist * sizeof(ball_state));
    b->n_hist = n_hist;
    b->state = predicted;
    publish(v, out);
    report(fi, b, t, confirmed);
    b->t_prev = t;
    b->has_t_prev = 1;
    return fmi2OK;
}

/* ===================================================================== restored states */
static fmi2Status check(fmu_instance *fi, const void *data, const double *v)
{
    const ball_in_shell *b = data;
    const char *why = NULL;
    (void)v;
    if (!(b->n_samples >= 1 && b->n_samples <= b->points)) why = "its input window has a wrong number of samples";
    else if (!(b->n_hist >= 1 && b->n_hist <= MAX_SAMPLES)) why = "its corrector history has a wrong length";
    else if (!(isfinite(b->state.t) && bm_all_finite(b->state.y, b->P.ny))) why = "its ball state is not finite";
    for (int i = 0; !why && i < b->n_samples; i++) {
        const double *s = &b->samples[i].t;
        for (int j = 0; j < 7; j++)
            if (!isfinite(s[j])) why = "an input sample is not finite";
        if (i && !(b->samples[i].t > b->samples[i - 1].t)) why = "its input samples are not in time order";
    }
    for (int i = 0; !why && i < b->n_hist; i++)
        if (!(isfinite(b->hist[i].t) && bm_all_finite(b->hist[i].y, b->P.ny))) why = "a corrected state is not finite";
    if (!why && b->P.form == BM_VECTOR) {
        double n2 = b->state.y[0] * b->state.y[0] + b->state.y[1] * b->state.y[1] + b->state.y[2] * b->state.y[2];
        if (!(fabs(n2 - 1.0) < 1e-9)) why = "its contact direction n is not a unit vector";
    }
    if (!why && b->P.form == BM_PAPER &&
        !(b->d * b->d - b->state.y[0] * b->state.y[0] - b->state.y[1] * b->state.y[1] > 0.0))
        why = "its ball centre lies at or beyond the chamber's equator";
    if (!why) return fmi2OK;
    fmu_log(fi, fmi2Error, "BallInShell '%s': FMU state refused: %s", fmu_instance_name(fi), why);
    return fmi2Error;
}

const fmu_model FMU_MODEL = {
    FMU_IDENTIFIER, FMU_GUID, FMU_N_VARS, FMU_VARIABLES,
    sizeof(ball_in_shell), offsetof(ball_in_shell, state),
    setup, step, check,
};
