/* ballmill/physics/_kernel.c: the compiled kernel for monolithic runs.
 *
 * The vector formulation of ballmill.physics (equations.py: n' = lambda n x omega,
 * omega' = k n x (a_O - g + r n' x omega), with the optional rolling resistance
 * and drag), the outputs of outputs.py (all fields of Outputs, in their order),
 * the platform motions of drives.py (CrankStartup, Fixed, Harmonic, Circle:
 * exact state(t)) and the explicit Runge-Kutta integrators of integrators.py
 * (DOP853, RK45, RK4) with the same step-size control, error norms, clipping
 * to the output points, carried step, renormalisation of n after every
 * accepted step and failure conditions.
 *
 * Every expression is written in the operation order of the Python code it
 * mirrors (sums left to right, zero tableau coefficients left out, Python's
 * max/min semantics), so that with IEEE double arithmetic and no contraction
 * into fused multiply-adds (build with -ffp-contract=off) the results are the
 * Python path's bit for bit. tests/test_kernel.py checks that.
 *
 * One interval at a time (bm_advance_interval) serves BallModel.advance, e.g.
 * in the BallInShell FMU, when the platform acceleration is the cubic
 * polynomial of platform.InputReconstruction (motion BM_POLY: only a(t) is
 * known, evaluated in the closure's operation order).
 *
 * Plain C99, no Python C API in the functions: ballmill/physics/fast.py calls
 * them through ctypes. Built by setup.py as the extension module
 * ballmill.physics._kernel (BALLMILL_KERNEL_MODULE defined: the PyInit at the
 * end makes it importable, which is all setuptools needs); the benchmark's
 * standalone C peer (ballmill/bench/compiled.py) #includes this file as it is.
 *
 * Failure: a step that Python would refuse (StepFailure, or the division by
 * zero of renormalising n = 0) makes bm_simulate stop at the last good output
 * point without committing that interval; fast.py then replays the interval in
 * Python, which raises the exception with its message. bm_simulate also hands
 * an adaptive interval back when it has no valid step size to start with
 * (Python's initial step belongs to the Python side).
 */
#ifdef BALLMILL_KERNEL_MODULE
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#endif

#include <math.h>
#include <stddef.h>
#include <string.h>

#ifdef _WIN32
#define BM_EXPORT __declspec(dllexport)
#else
#define BM_EXPORT __attribute__((visibility("default")))
#endif

#ifndef BM_SOURCE_HASH
#define BM_SOURCE_HASH 0ULL /* setup.py defines it: first 60 bits of this file's sha256 */
#endif

#define BM_ABI 2
#define BM_NY 6      /* states: nx, ny, nz, wx, wy, wz */
#define BM_NOUT 22   /* fields of outputs.Outputs */
#define BM_NS_MAX 12 /* stages of the largest tableau (DOP853) */

enum { BM_FIXED = 0, BM_CRANK = 1, BM_HARMONIC = 2, BM_CIRCLE = 3, BM_POLY = 4 };
#define BM_NMP 9 /* motion parameters */

/* Everything a run needs; filled by fast.py (ctypes mirror: fast._Problem). */
typedef struct {
    /* platform motion */
    int motion;       /* BM_FIXED, BM_CRANK, BM_HARMONIC, BM_CIRCLE, BM_POLY */
    double mp[BM_NMP]; /* crank: l, w0, t0; circle: l, w;
                          harmonic: x_amp, x_omega, y_amp, y_omega, x_phase, y_phase,
                          x_omega**2, y_omega**2 (powers taken in Python);
                          poly: t0, x0, x1, x2, x3, y0, y1, y2, y3 (a(t) only) */
    /* right-hand side (the formulation's ball) */
    int rhs_lossy;
    double rhs_lam, rhs_r, rhs_g, rhs_k;
    double rhs_loss[9]; /* equations.loss_constants: k, r, g, m, d, c d / m, delta, I + m r^2, eps^2 */
    /* outputs (the model's ball) */
    int out_lossy;
    double o_lam, o_r, o_d, o_R, o_m, o_g, o_k, o_mu;
    double o_cd;      /* drag * d */
    double o_delta;   /* rolling_resistance */
    double o_loss[9]; /* loss_constants */
    /* integrator */
    int ns, order, adaptive, has_e3;
    double A[BM_NS_MAX * BM_NS_MAX]; /* ns x ns, row-major, strictly lower triangular */
    double B[BM_NS_MAX];
    double C[BM_NS_MAX];
    double E[BM_NS_MAX + 1];
    double E3[BM_NS_MAX + 1];
    double tol, h_fixed, h_max;
    long long max_steps;
    double scale[BM_NY];
    double tols[BM_NY]; /* tol * scale */
} bm_problem;

typedef struct {
    long long steps, rejected, nfev;
} bm_stats;

/* ------------------------------------------------------------------ drives.py */
static void bm_motion_state(const bm_problem *P, double t, double o[6])
{
    const double *p = P->mp;
    switch (P->motion) {
    case BM_CRANK: { /* CrankStartup.angle / state */
        double l = p[0], w0 = p[1], t0 = p[2], psi, wd, wdd;
        if (t < 0.0) {
            psi = 0.0; wd = 0.0; wdd = 0.0;
        } else if (t <= t0) {
            double u = 1.0 - t / t0;
            psi = -w0 * pow(t - t0, 3.0) / (3.0 * t0 * t0) + w0 * t - w0 * t0 / 3.0;
            wd = w0 * (1.0 - u * u);
            wdd = 2.0 * w0 * u / t0;
        } else {
            psi = 2.0 / 3.0 * w0 * t0 + w0 * (t - t0);
            wd = w0;
            wdd = 0.0;
        }
        double c = cos(psi), s = sin(psi);
        o[0] = l * c;
        o[1] = l * s;
        o[2] = -l * s * wd;
        o[3] = l * c * wd;
        o[4] = -l * (s * wdd + c * wd * wd);
        o[5] = l * (c * wdd - s * wd * wd);
        return;
    }
    case BM_HARMONIC: {
        double xa = p[0], xw = p[1], ya = p[2], yw = p[3], xph = p[4], yph = p[5];
        double xw2 = p[6], yw2 = p[7];
        double sx = sin(xw * t + xph), cx = cos(xw * t + xph);
        double sy = sin(yw * t + yph), cy = cos(yw * t + yph);
        o[0] = xa * sx;
        o[1] = ya * sy;
        o[2] = xa * xw * cx;
        o[3] = ya * yw * cy;
        o[4] = -xa * xw2 * sx;
        o[5] = -ya * yw2 * sy;
        return;
    }
    case BM_CIRCLE: {
        double l = p[0], w = p[1];
        double c = cos(w * t), s = sin(w * t);
        o[0] = l * c;
        o[1] = l * s;
        o[2] = -l * w * s;
        o[3] = l * w * c;
        o[4] = -l * w * w * c;
        o[5] = -l * w * w * s;
        return;
    }
    case BM_POLY: { /* platform.InputReconstruction._compile_accel's closure: a(t) only */
        double s = t - p[0];
        o[0] = NAN; o[1] = NAN; o[2] = NAN; o[3] = NAN; /* not known (and not needed by bm_rhs) */
        o[4] = p[1] + s * (p[2] + s * (p[3] + s * p[4]));
        o[5] = p[5] + s * (p[6] + s * (p[7] + s * p[8]));
        return;
    }
    default: /* BM_FIXED */
        o[0] = 0.0; o[1] = 0.0; o[2] = 0.0; o[3] = 0.0; o[4] = 0.0; o[5] = 0.0;
        return;
    }
}

/* -------------------------------------------------------------- equations.py */
/* omega_dot_lossy(c, ...) */
static void bm_omega_dot_lossy(const double *c, double nx, double ny, double nz, double wx, double wy,
                               double wz, double ndx, double ndy, double ndz, double ax, double ay,
                               double *wd)
{
    double k = c[0], r = c[1], g = c[2], m = c[3], d = c[4], cd = c[5], delta = c[6], J = c[7],
           eps2 = c[8];
    double bx = ax + r * (ndy * wz - ndz * wy) + cd * ndx;
    double by = ay + r * (ndz * wx - ndx * wz) + cd * ndy;
    double bz = g + r * (ndx * wy - ndy * wx) + cd * ndz;
    double wdx = k * (ny * bz - nz * by), wdy = k * (nz * bx - nx * bz), wdz = k * (nx * by - ny * bx);
    if (delta != 0.0) {
        double N = m * (d * (ndx * ndx + ndy * ndy + ndz * ndz) - ax * nx - ay * ny - g * nz);
        if (N > 0.0) {
            double s = nx * wx + ny * wy + nz * wz;
            double tx = wx - s * nx, ty = wy - s * ny, tz = wz - s * nz;
            double f = -delta * N / (J * sqrt(tx * tx + ty * ty + tz * tz + eps2));
            wdx = wdx + f * tx;
            wdy = wdy + f * ty;
            wdz = wdz + f * tz;
        }
    }
    wd[0] = wdx; wd[1] = wdy; wd[2] = wdz;
}

/* VectorFormulation.derivative / _derivative_lossy */
static void bm_derivative(const bm_problem *P, const double *y, double ax, double ay, double *f)
{
    double nx = y[0], ny = y[1], nz = y[2], wx = y[3], wy = y[4], wz = y[5];
    double lam = P->rhs_lam;
    double ndx = lam * (ny * wz - nz * wy);
    double ndy = lam * (nz * wx - nx * wz);
    double ndz = lam * (nx * wy - ny * wx);
    f[0] = ndx; f[1] = ndy; f[2] = ndz;
    if (P->rhs_lossy) {
        bm_omega_dot_lossy(P->rhs_loss, nx, ny, nz, wx, wy, wz, ndx, ndy, ndz, ax, ay, f + 3);
        return;
    }
    double r = P->rhs_r, g = P->rhs_g, k = P->rhs_k;
    double bx = ax + r * (ndy * wz - ndz * wy);
    double by = ay + r * (ndz * wx - ndx * wz);
    double bz = g + r * (ndx * wy - ndy * wx);
    f[3] = k * (ny * bz - nz * by);
    f[4] = k * (nz * bx - nx * bz);
    f[5] = k * (nx * by - ny * bx);
}

/* BallModel.rhs: f(t, y) = derivative(y, *motion.accel(t)) */
static void bm_rhs(const bm_problem *P, double t, const double *y, double *f)
{
    double m[6];
    bm_motion_state(P, t, m);
    bm_derivative(P, y, m[4], m[5], f);
}

/* ----------------------------------------------------------------- outputs.py */
/* evaluate(ball, n, w, ax, ay, xO, yO) as the 22 fields of Outputs */
static void bm_outputs(const bm_problem *P, const double *y, double ax, double ay, double xO, double yO,
                       double *o)
{
    double nx = y[0], ny = y[1], nz = y[2], wx = y[3], wy = y[4], wz = y[5];
    double lam = P->o_lam, r = P->o_r, d = P->o_d, R = P->o_R, m = P->o_m, g = P->o_g;
    double ndx = lam * (ny * wz - nz * wy);
    double ndy = lam * (nz * wx - nx * wz);
    double ndz = lam * (nx * wy - ny * wx);
    double wd[3];
    if (P->out_lossy) {
        bm_omega_dot_lossy(P->o_loss, nx, ny, nz, wx, wy, wz, ndx, ndy, ndz, ax, ay, wd);
    } else { /* omega_dot(ball.k, r, g, ...) */
        double k = P->o_k;
        double bx = ax + r * (ndy * wz - ndz * wy);
        double by = ay + r * (ndz * wx - ndx * wz);
        double bz = g + r * (ndx * wy - ndy * wx);
        wd[0] = k * (ny * bz - nz * by);
        wd[1] = k * (nz * bx - nx * bz);
        wd[2] = k * (nx * by - ny * bx);
    }
    double wdx = wd[0], wdy = wd[1], wdz = wd[2];
    double nddx = lam * (ndy * wz - ndz * wy + ny * wdz - nz * wdy);
    double nddy = lam * (ndz * wx - ndx * wz + nz * wdx - nx * wdz);
    double nddz = lam * (ndx * wy - ndy * wx + nx * wdy - ny * wdx);
    double Fx, Fy, Fz, N, Ft, ratio, P_diss = 0.0;
    double MAx, MAy, MAz, sx, sy, sz;
    int contact;
    if (!P->out_lossy) {
        Fx = m * (ax + d * nddx);
        Fy = m * (ay + d * nddy);
        Fz = m * (d * nddz + g);
        N = -(Fx * nx + Fy * ny + Fz * nz);
        double ftx = Fx + N * nx, fty = Fy + N * ny, ftz = Fz + N * nz;
        Ft = sqrt(ftx * ftx + fty * fty + ftz * ftz);
        contact = N > 0.0;
        ratio = contact ? Ft / N : INFINITY;
        sx = -Fx; sy = -Fy; sz = -Fz;
        MAx = R * (ny * sz - nz * sy);
        MAy = R * (nz * sx - nx * sz);
        MAz = R * (nx * sy - ny * sx);
    } else { /* _evaluate_lossy */
        double Tx = m * (ax + d * nddx);
        double Ty = m * (ay + d * nddy);
        double Tz = m * (d * nddz + g);
        double cd = P->o_cd;
        double Fdx = -cd * ndx, Fdy = -cd * ndy, Fdz = -cd * ndz;
        Fx = Tx - Fdx; Fy = Ty - Fdy; Fz = Tz - Fdz;
        N = -(Fx * nx + Fy * ny + Fz * nz);
        double ftx = Fx + N * nx, fty = Fy + N * ny, ftz = Fz + N * nz;
        Ft = sqrt(ftx * ftx + fty * fty + ftz * ftz);
        contact = N > 0.0;
        ratio = contact ? Ft / N : INFINITY;
        double Mx = 0.0, My = 0.0, Mz = 0.0;
        P_diss = cd * d * (ndx * ndx + ndy * ndy + ndz * ndz);
        double delta = P->o_delta;
        if (delta != 0.0 && contact) {
            double s = nx * wx + ny * wy + nz * wz;
            double tx = wx - s * nx, ty = wy - s * ny, tz = wz - s * nz;
            double t2 = tx * tx + ty * ty + tz * tz;
            double f = -delta * N / sqrt(t2 + P->o_loss[8]);
            Mx = f * tx; My = f * ty; Mz = f * tz;
            P_diss -= f * t2;
        }
        sx = -Tx; sy = -Ty; sz = -Tz;
        double cx = -Fx, cy = -Fy, cz = -Fz;
        double ex = -Fdx, ey = -Fdy, ez = -Fdz;
        MAx = R * (ny * cz - nz * cy) + d * (ny * ez - nz * ey) - Mx;
        MAy = R * (nz * cx - nx * cz) + d * (nz * ex - nx * ez) - My;
        MAz = R * (nx * cy - ny * cx) + d * (nx * ey - ny * ex) - Mz;
    }
    o[0] = R * nx; o[1] = R * ny; o[2] = R * (1.0 + nz);
    o[3] = d * nx; o[4] = d * ny; o[5] = R + d * nz;
    o[6] = wx; o[7] = wy; o[8] = wz;
    o[9] = N; o[10] = sx; o[11] = sy; o[12] = sz;
    o[13] = xO * sy - yO * sx;
    o[14] = MAx; o[15] = MAy; o[16] = MAz;
    o[17] = Ft; o[18] = ratio;
    o[19] = contact ? 1.0 : 0.0;
    o[20] = (contact && Ft <= P->o_mu * N) ? 1.0 : 0.0;
    o[21] = P_diss;
}

/* ------------------------------------------------------------- integrators.py */
static double bm_pymax(double a, double b) { return b > a ? b : a; } /* Python's max(a, b) */
static double bm_pymin(double a, double b) { return b < a ? b : a; } /* Python's min(a, b) */

/* A row of tableau coefficients without its zeros (integrators._dot leaves them out) */
typedef struct {
    int n;
    int j[BM_NS_MAX + 1];
    double c[BM_NS_MAX + 1];
} bm_row;

/* the tableau as sparse rows, built once per run */
typedef struct {
    bm_row A[BM_NS_MAX], B, E, E3;
} bm_tab;

static void bm_row_make(bm_row *row, const double *c, int count)
{
    row->n = 0;
    for (int j = 0; j < count; j++)
        if (c[j] != 0.0) {
            row->j[row->n] = j;
            row->c[row->n] = c[j];
            row->n++;
        }
}

static void bm_tab_make(const bm_problem *P, bm_tab *T)
{
    for (int s = 0; s < P->ns; s++) bm_row_make(&T->A[s], P->A + s * P->ns, s);
    bm_row_make(&T->B, P->B, P->ns);
    bm_row_make(&T->E, P->E, P->ns + 1);
    bm_row_make(&T->E3, P->E3, P->ns + 1);
}

/* sum of c * K[j][i] over the row, left to right; 0.0 for an empty row */
static double bm_dot(const bm_row *row, double K[][BM_NY], int i)
{
    if (row->n == 0) return 0.0;
    double acc = row->c[0] * K[row->j[0]][i];
    for (int q = 1; q < row->n; q++) acc += row->c[q] * K[row->j[q]][i];
    return acc;
}

static int bm_all_finite(const double *v)
{
    for (int i = 0; i < BM_NY; i++)
        if (!isfinite(v[i])) return 0;
    return 1;
}

/* The stages of one step (integrators._kernel): K[0] = f(t, y) on entry; K[1..ns-1], y_new. */
static void bm_stages(const bm_problem *P, const bm_tab *T, double t, const double *y, double h,
                      double K[][BM_NY], double *ynew)
{
    int ns = P->ns;
    double yt[BM_NY];
    for (int s = 1; s < ns; s++) {
        for (int i = 0; i < BM_NY; i++) yt[i] = y[i] + bm_dot(&T->A[s], K, i) * h;
        bm_rhs(P, t + P->C[s] * h, yt, K[s]);
    }
    for (int i = 0; i < BM_NY; i++) ynew[i] = y[i] + h * bm_dot(&T->B, K, i);
}

/* error norm of the adaptive methods, K[ns] = f(t + h, y_new) (scaled tolerances) */
static double bm_error(const bm_problem *P, const bm_tab *T, double K[][BM_NY], double h, const double *y,
                       const double *yn)
{
    double sc[BM_NY];
    for (int i = 0; i < BM_NY; i++)
        sc[i] = P->tol * bm_pymax(bm_pymax(fabs(y[i]), fabs(yn[i])), P->scale[i]) + P->tols[i];
    if (!P->has_e3) {
        double sum = 0.0;
        for (int i = 0; i < BM_NY; i++) {
            double e = bm_dot(&T->E, K, i) * h / sc[i];
            sum = i ? sum + e * e : e * e;
        }
        return sqrt(sum / BM_NY);
    }
    double e5n = 0.0, e3n = 0.0;
    for (int i = 0; i < BM_NY; i++) {
        double e = bm_dot(&T->E, K, i) / sc[i];
        double g = bm_dot(&T->E3, K, i) / sc[i];
        e5n = i ? e5n + e * e : e * e;
        e3n = i ? e3n + g * g : g * g;
    }
    if (e5n == 0.0 && e3n == 0.0) return 0.0;
    return fabs(h) * e5n / sqrt((e5n + 0.01 * e3n) * BM_NY);
}

/* VectorFormulation.project; 0 when Python's 1.0 / sqrt(0) would raise */
static int bm_project(double *y)
{
    double q = sqrt(y[0] * y[0] + y[1] * y[1] + y[2] * y[2]);
    if (q == 0.0) return 0;
    double s = 1.0 / q;
    y[0] *= s; y[1] *= s; y[2] *= s;
    return 1;
}

/* Integrator.advance (the small-system path) from t to t_end. y and *h are
 * updated only on success (return 1); 0: Python must do this interval (it
 * fails there, or needs the initial step). */
static int bm_advance(const bm_problem *P, const bm_tab *T, double t, double *y_io, double t_end, double *h_io,
                      bm_stats *st)
{
    double K[BM_NS_MAX + 1][BM_NY], y[BM_NY], ynew[BM_NY];
    double span = t_end - t;
    if (span <= 0.0) return 1;
    memcpy(y, y_io, sizeof y);
    bm_rhs(P, t, y, K[0]);
    st->nfev++;
    if (!bm_all_finite(K[0])) return 0;
    int ns = P->ns;
    if (!P->adaptive) {
        double q = ceil(span / P->h_fixed - 1e-9);
        if (!(q <= (double)P->max_steps)) return 0; /* the work bound (Python raises StepFailure) */
        long long count = q < 1.0 ? 1 : (long long)q;
        double hh = span / (double)count;
        for (long long i = 0; i < count; i++) {
            double ti = t + (double)i * hh;
            if (i) {
                bm_rhs(P, ti, y, K[0]);
                st->nfev++;
            }
            bm_stages(P, T, ti, y, hh, K, ynew);
            st->nfev += ns - 1;
            if (!bm_all_finite(ynew)) return 0;
            memcpy(y, ynew, sizeof y);
            if (!bm_project(y)) return 0;
            st->steps++;
        }
        memcpy(y_io, y, sizeof y);
        *h_io = P->h_fixed;
        return 1;
    }
    double h = *h_io;
    if (!(h > 0.0 && isfinite(h))) return 0; /* the initial step is Python's */
    double order = (double)P->order;
    double h_min_abs = 1e-14 * bm_pymax(1.0, fabs(t_end));
    double t_last = t_end - 1e-12 * bm_pymax(1.0, fabs(t_end));
    while (t < t_end) {
        if (st->steps + st->rejected >= P->max_steps) return 0;
        h = bm_pymin(h, P->h_max);
        int last = t + h >= t_last;
        double hh = last ? t_end - t : h;
        bm_stages(P, T, t, y, hh, K, ynew);
        bm_rhs(P, t + hh, ynew, K[ns]);
        st->nfev += ns;
        double err = bm_error(P, T, K, hh, y, ynew);
        if (!(bm_all_finite(ynew) && isfinite(err))) {
            st->rejected++;
            h = 0.2 * hh;
            if (!(h >= h_min_abs)) return 0;
            continue;
        }
        if (err <= 1.0) {
            double factor = err == 0.0 ? 10.0 : bm_pymin(10.0, 0.9 * pow(err, -1.0 / order));
            t = last ? t_end : t + hh;
            memcpy(y, ynew, sizeof y);
            if (!bm_project(y)) return 0;
            memcpy(K[0], K[ns], sizeof K[0]);
            st->steps++;
            h = last ? bm_pymax(h, hh * factor) : hh * factor;
        } else {
            st->rejected++;
            h = hh * bm_pymax(0.2, 0.9 * pow(err, -1.0 / order));
            if (!(h >= h_min_abs)) return 0;
        }
    }
    memcpy(y_io, y, sizeof y);
    *h_io = h;
    return 1;
}

/* ------------------------------------------------------------------- model.py */
/* simulate's loop from output point `start` (state y, step *h) over times[start..n-1]:
 * records ys[i] (and the outputs outs[i] unless outs is NULL) for every point
 * reached (point `start` itself only if record_start), adds the work of the
 * completed intervals to *total and returns the index of the last point
 * reached; y and *h are then the state there. */
BM_EXPORT long long bm_simulate(const bm_problem *P, const double *times, long long n, long long start,
                                int record_start, double *y, double *h, double *ys, double *outs,
                                bm_stats *total)
{
    double m[6];
    bm_tab T;
    bm_tab_make(P, &T);
    for (long long i = start; i < n; i++) {
        if (i > start) {
            bm_stats st = {0, 0, 0};
            if (!bm_advance(P, &T, times[i - 1], y, times[i], h, &st)) return i - 1;
            total->steps += st.steps;
            total->rejected += st.rejected;
            total->nfev += st.nfev;
        } else if (!record_start) {
            continue;
        }
        memcpy(ys + BM_NY * i, y, BM_NY * sizeof(double));
        if (outs) {
            bm_motion_state(P, times[i], m);
            bm_outputs(P, y, m[4], m[5], m[0], m[1], outs + BM_NOUT * i);
        }
    }
    return n - 1;
}

/* BallModel.advance: one interval t -> t_end for the motion `motion` with the
 * parameters io[9..17] (instead of P's), as Integrator.advance does it.
 * io: t, t_end, h, y[6], motion parameters[9]. On success (1) io[2] and io[3..8]
 * hold the step to try next and the state at t_end; *st (zeroed here) the work.
 * 0: Python must do the interval (it fails there, or needs the initial step);
 * io is then unchanged. */
BM_EXPORT int bm_advance_interval(const bm_problem *P, int motion, double *io, bm_stats *st)
{
    bm_problem Q = *P;
    bm_tab T;
    double y[BM_NY], h = io[2];
    Q.motion = motion;
    memcpy(Q.mp, io + 3 + BM_NY, sizeof Q.mp);
    bm_tab_make(&Q, &T);
    memcpy(y, io + 3, sizeof y);
    st->steps = 0; st->rejected = 0; st->nfev = 0;
    if (!bm_advance(&Q, &T, io[0], y, io[1], &h, st)) return 0;
    io[2] = h;
    memcpy(io + 3, y, sizeof y);
    return 1;
}

/* Hairer-Wanner starting step as Integrator.initial_step (means summed left to
 * right). Not used by the library (fast.py takes Python's, whose numpy sums may
 * be ordered differently); the benchmark's standalone C peer needs one. */
BM_EXPORT double bm_initial_step(const bm_problem *P, double t, const double *y, double span)
{
    double sc[BM_NY], f0[BM_NY], f1[BM_NY], y1[BM_NY], d0 = 0.0, d1 = 0.0, d2 = 0.0;
    bm_rhs(P, t, y, f0);
    for (int i = 0; i < BM_NY; i++) {
        double b = bm_pymax(fabs(y[i]), P->scale[i]);
        sc[i] = P->tol * b + P->tols[i];
        d0 += (y[i] / sc[i]) * (y[i] / sc[i]);
        d1 += (f0[i] / sc[i]) * (f0[i] / sc[i]);
    }
    d0 = sqrt(d0 / BM_NY);
    d1 = sqrt(d1 / BM_NY);
    double h0 = (d0 < 1e-5 || d1 < 1e-5) ? 1e-6 : 0.01 * d0 / d1;
    h0 = bm_pymin(h0, span);
    for (int i = 0; i < BM_NY; i++) y1[i] = y[i] + h0 * f0[i];
    bm_rhs(P, t + h0, y1, f1);
    for (int i = 0; i < BM_NY; i++) {
        double e = (f1[i] - f0[i]) / sc[i];
        d2 += e * e;
    }
    d2 = sqrt(d2 / BM_NY) / h0;
    double h1 = (d1 <= 1e-15 && d2 <= 1e-15) ? bm_pymax(1e-6, h0 * 1e-3)
                                             : pow(0.01 / bm_pymax(d1, d2), 1.0 / P->order);
    return bm_pymin(bm_pymin(100 * h0, h1), P->h_max);
}

/* single evaluations, for tests */
BM_EXPORT void bm_eval_rhs(const bm_problem *P, double t, const double *y, double *f) { bm_rhs(P, t, y, f); }
BM_EXPORT void bm_eval_motion(const bm_problem *P, double t, double *o) { bm_motion_state(P, t, o); }
BM_EXPORT void bm_eval_outputs(const bm_problem *P, const double *y, double ax, double ay, double xO,
                               double yO, double *o)
{
    bm_outputs(P, y, ax, ay, xO, yO, o);
}

/* what fast.py checks before it trusts this build */
BM_EXPORT int bm_abi(void) { return BM_ABI; }
BM_EXPORT size_t bm_problem_size(void) { return sizeof(bm_problem); }
BM_EXPORT unsigned long long bm_source_hash(void) { return BM_SOURCE_HASH; }

#ifdef BALLMILL_KERNEL_MODULE
/* An importable (empty) extension module, so that setuptools can build and
 * install this file; the functions above are reached through ctypes. */
static struct PyModuleDef bm_module = {
    PyModuleDef_HEAD_INIT, "_kernel",
    "Compiled kernel of ballmill.physics (C functions loaded with ctypes by ballmill.physics.fast).",
    -1, NULL, NULL, NULL, NULL, NULL};

PyMODINIT_FUNC PyInit__kernel(void) { return PyModule_Create(&bm_module); }
#endif
