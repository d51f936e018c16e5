/* ballmill/physics/_kernel.c: the compiled kernel for monolithic runs.
 *
 * The vector formulation of ballmill.physics (equations.py: n' = lambda n x omega,
 * omega' = k n x (a_O - g + r n' x omega), with the optional rolling resistance
 * and drag), the outputs of outputs.py (all fields of Outputs, in their order),
 * the platform motions of drives/crank.py (CrankStartup, Fixed, Harmonic, Circle:
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
 * The ball absorber (a modal structure carrying the cavity, absorber/model.py) has
 * a right-hand side of its own, bma_*, reached through ballmill/absorber/kernel.py,
 * and runs on the same integrator (bm_advance, form BM_ABSORBER).
 *
 * The general model of a chamber that moves in 3-D and turns (turning/model.py and
 * turning/motions.py; docs/design.md section 10) has functions of its own, bmg_* at the end
 * of the file, reached through ballmill/physics/turning/kernel.py; they run on the
 * same integrator (bm_advance) but leave the translation-only functions as they are.
 *
 * Every run over a grid of output points (bm_simulate_study, bmg_simulate, bma_simulate,
 * bmh_simulate) is a system of the one grid loop bm_drive (events.integrate), which
 * integrates with the one integration routine bm_advance_seen (events located on its
 * accepted steps when the system's mode has guards).
 *
 * The hybrid ball (rolling, sliding, flight, impacts; hybrid.py), bmh_* at the end of the
 * file, reached through fast.hybrid_run.
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

#include "crank_law.h" /* the crank start-up law and the platform point, shared with the drive FMUs */

#ifdef _WIN32
#define BM_EXPORT __declspec(dllexport)
#else
#define BM_EXPORT __attribute__((visibility("default")))
#endif

#ifndef BM_SOURCE_HASH
#define BM_SOURCE_HASH 0ULL /* setup.py defines it: first 60 bits of this file's sha256 */
#endif

#define BM_ABI 6
#define BM_NY 6      /* the ball's states, at most: nx, ny, nz, wx, wy, wz (vector); xC, yC, wx, wy, wz (paper) */
#define BM_NYMAX 25  /* states the integrators carry, at most (the native induction motor FMU: 7;
                        the absorber's coupled state: 4 * BMA_MODES + 9) */
#define BM_NOUT 24   /* fields of outputs.Outputs */
#define BM_NS_MAX 12 /* stages of the largest tableau (DOP853) */

enum { BM_FIXED = 0, BM_CRANK = 1, BM_HARMONIC = 2, BM_CIRCLE = 3, BM_POLY = 4, BM_POLY_KIN = 5 };
/* start-up laws of BM_CRANK, in the order of drives.LAWS */
/* CrankStartup.law as its index in drives.LAWS (quadratic, linear, scurve, quintic) -> crank_law.h's shape */
static const int BM_STARTUP_LAW[4] = {STARTUP_QUADRATIC, STARTUP_LINEAR, STARTUP_SCURVE, STARTUP_QUINTIC};
enum { BM_VECTOR = 0, BM_PAPER = 1, BM_GENERIC = 2, BM_ABSORBER = 3 }; /* formulations */
#define BM_NMP 9 /* motion parameters */

/* Everything a run needs; filled by fast.py (ctypes mirror: fast._Problem). */
typedef struct {
    /* platform motion */
    int motion;       /* BM_FIXED, BM_CRANK, BM_HARMONIC, BM_CIRCLE, BM_POLY, BM_POLY_KIN */
    double mp[BM_NMP]; /* crank: l, w0, t0, law; circle: l, w;
                          harmonic: x_amp, x_omega, y_amp, y_omega, x_phase, y_phase,
                          x_omega**2, y_omega**2 (powers taken in Python);
                          poly: t0, x0, x1, x2, x3, y0, y1, y2, y3 (a(t) only; BM_POLY_KIN:
                          the same a(t) with the position and velocity, mp_kin) */
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
    /* the material bed (equations.bed_constants: R, h, w), of the formulation's ball and of
     * the model's; has_bed 0: the material fills the chamber */
    int rhs_has_bed, o_has_bed;
    double rhs_bed[3], o_bed[3];
    /* integrator */
    int ns, order, adaptive, has_e3;
    double A[BM_NS_MAX * BM_NS_MAX]; /* ns x ns, row-major, strictly lower triangular */
    double B[BM_NS_MAX];
    double C[BM_NS_MAX];
    double E[BM_NS_MAX + 1];
    double E3[BM_NS_MAX + 1];
    double tol, h_fixed, h_max;
    long long max_steps;
    double scale[BM_NYMAX];
    double tols[BM_NYMAX]; /* tol * scale */
    /* formulation: BM_VECTOR (ny = 6; the library's kernel uses only this) or BM_PAPER
     * (ny = 5, the paper's (xC, yC, omega) of equations.PaperFormulation with d = R - r
     * and its equator margin; the native BallInShell FMU uses it), or BM_GENERIC (any
     * ny <= BM_NYMAX, a right-hand side of the caller's, no projection: the native
     * induction motor FMU), or BM_ABSORBER (any ny <= BM_NYMAX, the absorber's right-hand
     * side bma_rhs; the projection puts the ball's n, y[ny - 9 .. ny - 7], on the unit sphere) */
    int form, ny;
    double pap_d, pap_margin;
    /* BM_POLY_KIN (the hybrid ball's chamber in the native BallInShell FMU: BM_POLY's a(t) integrated
     * exactly from O's position and velocity at t0 = mp[0], platform.ReconstructedPlatform): x0, vx0,
     * y0, vy0, then a_j / ((j + 1) (j + 2)) of x and of y, then a_j / (j + 1) of x and of y (j = 0..3) */
    double mp_kin[20];
    /* the states the error norm and the initial step weigh: the first nerr (0: all ny); the
     * rest are quadratures riding along (Integrator's n_err) */
    int nerr;
} bm_problem;

typedef struct {
    long long steps, rejected, nfev;
} bm_stats;

/* ------------------------------------------------------------------ drives/crank.py */
static void bm_motion_state(const bm_problem *P, double t, double o[6])
{
    const double *p = P->mp;
    switch (P->motion) {
    case BM_CRANK: { /* CrankStartup.angle / state; p[3]: the law (drives.LAWS index) */
        double ps[3];
        startup_angle(BM_STARTUP_LAW[(int)p[3]], p[1], p[2], t, ps);
        crank_point c = crank_kinematics(p[0], ps[0], ps[1], ps[2]);
        o[0] = c.x;
        o[1] = c.y;
        o[2] = c.vx;
        o[3] = c.vy;
        o[4] = c.ax;
        o[5] = c.ay;
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
    case BM_POLY_KIN: { /* platform.ReconstructedPlatform.state: BM_POLY's a(t), x and v its exact integrals */
        double s = t - p[0];
        const double *q = P->mp_kin, *px = q + 4, *py = q + 8, *qx = q + 12, *qy = q + 16;
        o[0] = q[0] + s * (q[1] + s * (px[0] + s * (px[1] + s * (px[2] + s * px[3]))));
        o[1] = q[2] + s * (q[3] + s * (py[0] + s * (py[1] + s * (py[2] + s * py[3]))));
        o[2] = q[1] + s * (qx[0] + s * (qx[1] + s * (qx[2] + s * qx[3])));
        o[3] = q[3] + s * (qy[0] + s * (qy[1] + s * (qy[2] + s * qy[3])));
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
/* omega_dot(k, r, g, ...): k n x (a + r n' x omega + g e_z), a = (ax, ay, 0) */
static void bm_omega_dot(double k, double r, double g, double nx, double ny, double nz, double wx, double wy,
                         double wz, double ndx, double ndy, double ndz, double ax, double ay, double *wd)
{
    double bx = ax + r * (ndy * wz - ndz * wy);
    double by = ay + r * (ndz * wx - ndx * wz);
    double bz = g + r * (ndx * wy - ndy * wx);
    wd[0] = k * (ny * bz - nz * by);
    wd[1] = k * (nz * bx - nx * bz);
    wd[2] = k * (nx * by - ny * bx);
}

/* equations.bed_share(bed, nz): the share of the material's resistance at the contact point */
static double bm_bed_share(const double *bed, double nz)
{
    double x = (bed[1] - bed[0] * (1.0 + nz)) / bed[2];
    if (x <= 0.0) return 0.0;
    if (x >= 1.0) return 1.0;
    double e = 1.0 / x - 1.0 / (1.0 - x);
    if (e > 0.0) {
        double q = exp(-e);
        return q / (1.0 + q);
    }
    double q = exp(e);
    return 1.0 / (1.0 + q);
}

/* omega_dot_lossy(c, ..., bed): bed NULL when the material fills the chamber */
static void bm_omega_dot_lossy(const double *c, double nx, double ny, double nz, double wx, double wy,
                               double wz, double ndx, double ndy, double ndz, double ax, double ay,
                               const double *bed, double *wd)
{
    double k = c[0], r = c[1], g = c[2], m = c[3], d = c[4], cd = c[5], delta = c[6], J = c[7],
           eps2 = c[8];
    if (bed) {
        double s = bm_bed_share(bed, nz);
        cd = cd * s;
        delta = delta * s;
    }
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

/* PaperFormulation.derivative / _derivative_lossy (closed form). Past the equator
 * (Python: FormulationLimitError) the derivative is NaN, which no step accepts. */
static void bm_derivative_paper(const bm_problem *P, const double *y, double ax, double ay, double *f)
{
    double xC = y[0], yC = y[1], wx = y[2], wy = y[3], wz = y[4];
    double lam = P->rhs_lam, d = P->pap_d, r = P->rhs_r, g = P->rhs_g, k = P->rhs_k;
    double s2 = d * d - xC * xC - yC * yC;
    if (!(s2 > 0.0)) {
        for (int i = 0; i < 5; i++) f[i] = NAN;
        return;
    }
    double s = sqrt(s2);
    double xd = lam * (wy * s + wz * yC);
    double yd = -lam * (wx * s + wz * xC);
    double zd = (xC * xd + yC * yd) / s;
    double nx = xC / d, ny = yC / d, nz = -s / d;
    double ndx = xd / d, ndy = yd / d, ndz = zd / d;
    f[0] = xd; f[1] = yd;
    if (P->rhs_lossy) {
        bm_omega_dot_lossy(P->rhs_loss, nx, ny, nz, wx, wy, wz, ndx, ndy, ndz, ax, ay,
                           P->rhs_has_bed ? P->rhs_bed : NULL, f + 2);
        return;
    }
    bm_omega_dot(k, r, g, nx, ny, nz, wx, wy, wz, ndx, ndy, ndz, ax, ay, f + 2);
}

/* VectorFormulation.derivative / _derivative_lossy */
static void bm_derivative(const bm_problem *P, const double *y, double ax, double ay, double *f)
{
    if (P->form == BM_PAPER) {
        bm_derivative_paper(P, y, ax, ay, f);
        return;
    }
    double nx = y[0], ny = y[1], nz = y[2], wx = y[3], wy = y[4], wz = y[5];
    double lam = P->rhs_lam;
    double ndx = lam * (ny * wz - nz * wy);
    double ndy = lam * (nz * wx - nx * wz);
    double ndz = lam * (nx * wy - ny * wx);
    f[0] = ndx; f[1] = ndy; f[2] = ndz;
    if (P->rhs_lossy) {
        bm_omega_dot_lossy(P->rhs_loss, nx, ny, nz, wx, wy, wz, ndx, ndy, ndz, ax, ay,
                           P->rhs_has_bed ? P->rhs_bed : NULL, f + 3);
        return;
    }
    bm_omega_dot(P->rhs_k, P->rhs_r, P->rhs_g, nx, ny, nz, wx, wy, wz, ndx, ndy, ndz, ax, ay, f + 3);
}

/* BallModel.rhs: f(t, y) = derivative(y, *motion.accel(t)) */
static void bm_rhs(const bm_problem *P, double t, const double *y, double *f)
{
    double m[6];
    bm_motion_state(P, t, m);
    bm_derivative(P, y, m[4], m[5], f);
}

/* ----------------------------------------------------------------- outputs.py */
/* evaluate(ball, n, w, ax, ay, xO, yO) as the 24 fields of Outputs */
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
        bm_omega_dot_lossy(P->o_loss, nx, ny, nz, wx, wy, wz, ndx, ndy, ndz, ax, ay,
                           P->o_has_bed ? P->o_bed : NULL, wd);
    } else { /* omega_dot(ball.k, r, g, ...) */
        bm_omega_dot(P->o_k, r, g, nx, ny, nz, wx, wy, wz, ndx, ndy, ndz, ax, ay, wd);
    }
    double wdx = wd[0], wdy = wd[1], wdz = wd[2];
    double nddx = lam * (ndy * wz - ndz * wy + ny * wdz - nz * wdy);
    double nddy = lam * (ndz * wx - ndx * wz + nz * wdx - nx * wdz);
    double nddz = lam * (ndx * wy - ndy * wx + nx * wdy - ny * wdx);
    double Fx, Fy, Fz, N, Ft, ratio, P_diss = 0.0;
    double share = P->o_has_bed ? bm_bed_share(P->o_bed, nz) : 1.0;
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
        double cd = P->o_cd, delta = P->o_delta;
        if (P->o_has_bed) {
            cd = cd * share;
            delta = delta * share;
        }
        double Fdx = -cd * ndx, Fdy = -cd * ndy, Fdz = -cd * ndz;
        Fx = Tx - Fdx; Fy = Ty - Fdy; Fz = Tz - Fdz;
        N = -(Fx * nx + Fy * ny + Fz * nz);
        double ftx = Fx + N * nx, fty = Fy + N * ny, ftz = Fz + N * nz;
        Ft = sqrt(ftx * ftx + fty * fty + ftz * ftz);
        contact = N > 0.0;
        ratio = contact ? Ft / N : INFINITY;
        double Mx = 0.0, My = 0.0, Mz = 0.0;
        P_diss = cd * d * (ndx * ndx + ndy * ndy + ndz * ndz);
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
    o[22] = P_diss; /* P_grind: the rolling model loses energy to the material only */
    o[23] = share;
}

/* ------------------------------------------------------------- integrators.py */
/* the right-hand side an integrator calls: the ball's (bm_ball_rhs), or another model's
 * with its own context (the native induction motor FMU) */
typedef void (*bm_rhs_fn)(const bm_problem *P, const void *ctx, double t, const double *y, double *f);

static void bm_ball_rhs(const bm_problem *P, const void *ctx, double t, const double *y, double *f)
{
    (void)ctx;
    bm_rhs(P, t, y, f);
}

static double bm_pymax(double a, double b) { return b > a ? b : a; } /* Python's max(a, b) */
static double bm_pymin(double a, double b) { return b < a ? b : a; } /* Python's min(a, b) */

/* Python's x ** 2 is libm's pow, which rounds differently from x * x about once in a
 * thousand; the exponent is read through a volatile so that the compiler cannot fold
 * pow(x, 2.0) into x * x */
static volatile double bm_two = 2.0;
static double bm_sq(double x) { return pow(x, bm_two); }

/* A row of tableau coefficients without its zeros (integrators._dot leaves them out);
 * the stages they weigh as offsets into the packed stage derivatives K */
typedef struct {
    int n;
    int j[BM_NS_MAX + 1]; /* stage j's derivative is K[j * ny .. j * ny + ny - 1] */
    double c[BM_NS_MAX + 1];
} bm_row;

/* the tableau as sparse rows for a problem's ny states, built once per run */
typedef struct {
    bm_row A[BM_NS_MAX], B, E, E3;
} bm_tab;

static void bm_row_make(bm_row *row, const double *c, int count, int ny)
{
    row->n = 0;
    for (int j = 0; j < count; j++)
        if (c[j] != 0.0) {
            row->j[row->n] = j * ny;
            row->c[row->n] = c[j];
            row->n++;
        }
}

static void bm_tab_make(const bm_problem *P, bm_tab *T)
{
    for (int s = 0; s < P->ns; s++) bm_row_make(&T->A[s], P->A + s * P->ns, s, P->ny);
    bm_row_make(&T->B, P->B, P->ns, P->ny);
    bm_row_make(&T->E, P->E, P->ns + 1, P->ny);
    bm_row_make(&T->E3, P->E3, P->ns + 1, P->ny);
}

/* The stages' derivatives K are packed: stage s's ny values at K + s * ny (a fixed
 * stride of BM_NYMAX, the absorber's 25, cost the ball's 6 states 2-4 % in time) */
#define BM_K(K, s, ny) ((K) + (size_t)(s) * (size_t)(ny))

/* sum of c * K_j[i] over the row, left to right; 0.0 for an empty row */
static double bm_dot(const bm_row *row, const double *K, int i)
{
    if (row->n == 0) return 0.0;
    double acc = row->c[0] * K[row->j[0] + i];
    for (int q = 1; q < row->n; q++) acc += row->c[q] * K[row->j[q] + i];
    return acc;
}

static int bm_all_finite(const double *v, int n)
{
    for (int i = 0; i < n; i++)
        if (!isfinite(v[i])) return 0;
    return 1;
}

/* The stages of one step (integrators._kernel): K_0 = f(t, y) on entry; K_1..K_ns-1, y_new. */
static void bm_stages(const bm_problem *P, const bm_tab *T, bm_rhs_fn rhs, const void *ctx, double t,
                      const double *y, double h, double *K, double *ynew)
{
    int ns = P->ns, ny = P->ny;
    double yt[BM_NYMAX];
    for (int s = 1; s < ns; s++) {
        for (int i = 0; i < ny; i++) yt[i] = y[i] + bm_dot(&T->A[s], K, i) * h;
        rhs(P, ctx, t + P->C[s] * h, yt, BM_K(K, s, ny));
    }
    for (int i = 0; i < ny; i++) ynew[i] = y[i] + h * bm_dot(&T->B, K, i);
}

/* error norm of the adaptive methods, K_ns = f(t + h, y_new) (scaled tolerances) */
static double bm_error(const bm_problem *P, const bm_tab *T, const double *K, double h, const double *y,
                       const double *yn)
{
    double sc[BM_NYMAX];
    int ny = P->nerr > 0 ? P->nerr : P->ny; /* the controlled states */
    for (int i = 0; i < ny; i++)
        sc[i] = P->tol * bm_pymax(bm_pymax(fabs(y[i]), fabs(yn[i])), P->scale[i]) + P->tols[i];
    if (!P->has_e3) {
        double sum = 0.0;
        for (int i = 0; i < ny; i++) {
            double e = bm_dot(&T->E, K, i) * h / sc[i];
            sum = i ? sum + e * e : e * e;
        }
        return sqrt(sum / ny);
    }
    double e5n = 0.0, e3n = 0.0;
    for (int i = 0; i < ny; i++) {
        double e = bm_dot(&T->E, K, i) / sc[i];
        double g = bm_dot(&T->E3, K, i) / sc[i];
        e5n = i ? e5n + e * e : e * e;
        e3n = i ? e3n + g * g : g * g;
    }
    if (e5n == 0.0 && e3n == 0.0) return 0.0;
    return fabs(h) * e5n / sqrt((e5n + 0.01 * e3n) * ny);
}

/* after an accepted step: VectorFormulation.project (0 when Python's 1.0 / sqrt(0)
 * would raise), or PaperFormulation.check (0 within the equator margin, where Python
 * raises FormulationLimitError), or the absorber's StructureBall.project (as the vector
 * formulation's, on the ball's part of the state, with model.py's ** 2) */
static int bm_project(const bm_problem *P, double *y)
{
    if (P->form == BM_PAPER) {
        double d = P->pap_d, s2 = d * d - y[0] * y[0] - y[1] * y[1];
        return s2 > 0.0 && !(sqrt(s2) < P->pap_margin * d);
    }
    if (P->form == BM_GENERIC) return 1;
    if (P->form == BM_ABSORBER) {
        double *n = y + P->ny - 9;
        double q = sqrt(bm_sq(n[0]) + bm_sq(n[1]) + bm_sq(n[2])); /* model.py: z[ib] ** 2 + ... */
        if (q == 0.0) return 0;
        double s = 1.0 / q;
        n[0] *= s; n[1] *= s; n[2] *= s;
        return 1;
    }
    double q = sqrt(y[0] * y[0] + y[1] * y[1] + y[2] * y[2]);
    if (q == 0.0) return 0;
    double s = 1.0 / q;
    y[0] *= s; y[1] *= s; y[2] *= s;
    return 1;
}

/* The platform motion at the last few times asked, for bm_simulate_study: RK4 asks for the
 * same time twice in a step (stages 2 and 3), and the outputs and the next step ask again for
 * the time a step ends; a time met before (the same double) gets the state computed then,
 * which is what computing it again would give. */
#define BM_MCACHE 4
typedef struct {
    double t[BM_MCACHE], m[BM_MCACHE][6];
    int n, next;
} bm_mcache;

static void bm_motion_cached(const bm_problem *P, bm_mcache *c, double t, double m[6])
{
    for (int k = 0; k < c->n; k++)
        if (c->t[k] == t) {
            memcpy(m, c->m[k], sizeof c->m[k]);
            return;
        }
    bm_motion_state(P, t, m);
    c->t[c->next] = t;
    memcpy(c->m[c->next], m, sizeof c->m[c->next]);
    c->next = (c->next + 1) % BM_MCACHE;
    if (c->n < BM_MCACHE) c->n++;
}

/* bm_rhs with the motion from the cache ctx */
static void bm_ball_rhs_cached(const bm_problem *P, const void *ctx, double t, const double *y, double *f)
{
    double m[6];
    bm_motion_cached(P, (bm_mcache *)ctx, t, m);
    bm_derivative(P, y, m[4], m[5], f);
}

/* The global error of a fixed-step run, estimated from the run itself (no second run, no
 * extra stage): bm_advance_seen shows it every state the run accepts with its derivative
 * (t_k, y_k, f_k = f(t_k, y_k), which the next step computes anyway). The residual of the
 * run's states against a quadrature of order 5 of their own derivatives,
 *     rho_k = y_{k+1} - y_k - h sum_j w_j f_j   (j over 5 consecutive states, Newton-Cotes
 *                                                weights of the interval [t_k, t_k+1]; after the
 *                                                first four intervals, the Adams-Moulton formula),
 * is the step's local error to O(h^6): the run's global error e_k = y_k - y(t_k) is smooth,
 * and the quadrature of the exact solution errs by O(h^6) only, so rho_k = e_{k+1} - e_k -
 * (the quadrature of J e) + O(h^6) = the error the step adds (RK4's O(h^5)). The estimate
 * accumulates the local errors' effect on the outputs without cancellation: the contact point
 * P = R n moves by R |rho_k's part across n|, N by |N(y_{k+1}) - N(y_{k+1} - rho_k)| (N in closed form,
 * bm_normal_force); summed
 * over the steps (the error carried along the rolling ball adds up, as a phase error does).
 * docs/design.md's numerics section and tests/test_sweep_one_pass.py: on a grid of points it
 * stays within a stated factor of the error against a run at h/16. */
#define BM_LE_N 5
typedef struct {
    const bm_problem *P;
    bm_mcache *cache; /* the run's platform motion (for N) */
    int k;            /* states held (the last BM_LE_N, oldest first) */
    int started;      /* the first four intervals are done */
    double t[BM_LE_N], y[BM_LE_N][BM_NY], f[BM_LE_N][BM_NY];
    double err_P, err_N; /* accumulated [m], [N] */
} bm_lerr;

/* Newton-Cotes weights of the interval [t_i, t_i+1] of m equidistant states (m = 2..5), over a
 * common denominator: bm_le_w[m - 2][i][j] / bm_le_den[m - 2]; five states after the first
 * four intervals (the last row: Adams-Moulton), fewer only for a run that ends before
 * (a residual of lower order: a larger estimate) */
static const double bm_le_w[4][4][BM_LE_N] = {
    {{1.0, 1.0}},
    {{5.0, 8.0, -1.0}, {-1.0, 8.0, 5.0}},
    {{9.0, 19.0, -5.0, 1.0}, {-1.0, 13.0, 13.0, -1.0}, {1.0, -5.0, 19.0, 9.0}},
    {{251.0, 646.0, -264.0, 106.0, -19.0}, {-19.0, 346.0, 456.0, -74.0, 11.0},
     {11.0, -74.0, 456.0, 346.0, -19.0}, {-19.0, 106.0, -264.0, 646.0, 251.0}}};
static const double bm_le_den[4] = {2.0, 12.0, 24.0, 720.0};

static double bm_normal_force(const bm_problem *P, bm_mcache *c, double t, const double *y);

/* the residual of the interval i -> i + 1 of the m states held, added to the estimate */
static void bm_lerr_interval(bm_lerr *E, int i, int m)
{
    const bm_problem *P = E->P;
    const double *w = bm_le_w[m - 2][i], den = bm_le_den[m - 2];
    double h = (E->t[m - 1] - E->t[0]) / (m - 1), rho[BM_NY], yb[BM_NY];
    const double *y1 = E->y[i + 1];
    for (int q = 0; q < BM_NY; q++) {
        double s = 0.0;
        for (int j = 0; j < m; j++) s += w[j] * E->f[j][q];
        rho[q] = y1[q] - E->y[i][q] - h * (s / den);
        yb[q] = y1[q] - rho[q];
    }
    double rn = rho[0] * y1[0] + rho[1] * y1[1] + rho[2] * y1[2];
    double tx = rho[0] - rn * y1[0], ty = rho[1] - rn * y1[1], tz = rho[2] - rn * y1[2];
    E->err_P += P->o_R * sqrt(tx * tx + ty * ty + tz * tz);
    E->err_N += fabs(bm_normal_force(P, E->cache, E->t[i + 1], y1) - bm_normal_force(P, E->cache, E->t[i + 1], yb));
}

/* the run ended: intervals not yet estimated (a run of fewer than five states) with the states
 * there are (a run that made no step has no error) */
static void bm_lerr_end(bm_lerr *E)
{
    if (!E->started && E->k >= 2) {
        for (int i = 0; i < E->k - 1; i++) bm_lerr_interval(E, i, E->k);
        E->started = 1;
    }
}

/* a state the run accepted, with its derivative; states not equally spaced (a step that
 * changed) start the history afresh, keeping what is accumulated */
static void bm_lerr_see(bm_lerr *E, double t, const double *y, const double *f)
{
    if (E->k >= 2) {
        double h0 = E->t[1] - E->t[0], h1 = t - E->t[E->k - 1];
        if (!(fabs(h1 - h0) <= 1e-9 * fabs(h0))) {
            E->k = 0;
            E->started = 0;
        }
    }
    if (E->k == BM_LE_N) {
        memmove(E->t, E->t + 1, (BM_LE_N - 1) * sizeof E->t[0]);
        memmove(E->y, E->y + 1, (BM_LE_N - 1) * sizeof E->y[0]);
        memmove(E->f, E->f + 1, (BM_LE_N - 1) * sizeof E->f[0]);
        E->k--;
    }
    E->t[E->k] = t;
    memcpy(E->y[E->k], y, sizeof E->y[0]);
    memcpy(E->f[E->k], f, sizeof E->f[0]);
    E->k++;
    if (E->k < BM_LE_N) return;
    if (!E->started) {
        for (int i = 0; i < BM_LE_N - 1; i++) bm_lerr_interval(E, i, BM_LE_N);
        E->started = 1;
    } else {
        bm_lerr_interval(E, BM_LE_N - 2, BM_LE_N);
    }
}

/* Integrator.advance (the small-system path) from t to t_end. y and *h are
 * updated only on success (return 1); 0: Python must do this interval (it
 * fails there, or needs the initial step). */
typedef struct bm_events bm_events;
static int bm_advance_seen(const bm_problem *P, const bm_tab *T, bm_rhs_fn rhs, const void *ctx, double t,
                           double *y_io, double t_end, double *h_io, bm_stats *st, bm_lerr *seen,
                           bm_events *ev);

static int bm_advance(const bm_problem *P, const bm_tab *T, bm_rhs_fn rhs, const void *ctx, double t,
                      double *y_io, double t_end, double *h_io, bm_stats *st)
{
    return bm_advance_seen(P, T, rhs, ctx, t, y_io, t_end, h_io, st, NULL, NULL);
}

/* ------------------------------------------------------------------ events.py
 * Event location on the integrator's accepted steps, as events.integrate does it: after
 * each accepted step the armed guards are scanned on the step's cubic Hermite interpolant
 * (`_detect`), and a guard that changes sign is located on the method's own step from the
 * step's start (`_locate`, `Integrator.single_step`) by the Illinois variant of regula falsi
 * (`illinois`). bm_advance_seen with an event set stops at the first event (returns 2). */
#define BM_NG_MAX 4 /* guards of a mode, at most */
typedef void (*bm_guard_fn)(const void *ctx, double t, const double *y, double *g);

struct bm_events {
    /* the mode's guards: ng values G(ctx, t, y), each armed once above its level */
    int ng;
    bm_guard_fn G;
    const void *gctx;
    double levels[BM_NG_MAX];
    int armed[BM_NG_MAX];
    int scan;    /* interior points of the Hermite scan (events.integrate's scan) */
    double xtol; /* the root finder's bracket [s] */
    /* the event found: guard j at time t, the state y there, the bracket's width, the step's size */
    int j;
    double t, y[BM_NYMAX], width, h_used;
};

/* Step.hermite: y(t) on the cubic through (t0, y0, f0) and (t1, y1, f1) */
static void bm_hermite(int ny, double t0, const double *y0, const double *f0, double t1, const double *y1,
                       const double *f1, double t, double *out)
{
    double h = t1 - t0;
    double s = (t - t0) / h;
    double s2 = s * s, s3 = s * s * s;
    double h00 = 2.0 * s3 - 3.0 * s2 + 1.0, h10 = s3 - 2.0 * s2 + s, h01 = -2.0 * s3 + 3.0 * s2, h11 = s3 - s2;
    double a = h * h10, b = h * h11;
    for (int i = 0; i < ny; i++) out[i] = h00 * y0[i] + h01 * y1[i] + a * f0[i] + b * f1[i];
}

/* the state of a step at t (events._locate's state(t)): the ends as they are, inside one step
 * of the method from the start (Integrator.single_step: the stages, then the projection) */
typedef struct {
    const bm_problem *P;
    const bm_tab *T;
    bm_rhs_fn rhs;
    const void *ctx;
    double t0, t1;
    const double *y0, *f0, *y1;
    bm_events *ev;
    double K[(BM_NS_MAX + 1) * BM_NYMAX];
} bm_stepx;

static void bm_stepx_state(bm_stepx *x, double t, double *y)
{
    int ny = x->P->ny;
    if (t == x->t0) {
        memcpy(y, x->y0, (size_t)ny * sizeof(double));
        return;
    }
    if (t == x->t1) {
        memcpy(y, x->y1, (size_t)ny * sizeof(double));
        return;
    }
    memcpy(x->K, x->f0, (size_t)ny * sizeof(double));
    bm_stages(x->P, x->T, x->rhs, x->ctx, x->t0, x->y0, t - x->t0, x->K, y);
    bm_project(x->P, y);
}

static double bm_phi(bm_stepx *x, int j, double t)
{
    double y[BM_NYMAX], g[BM_NG_MAX];
    bm_stepx_state(x, t, y);
    x->ev->G(x->ev->gctx, t, y, g);
    return g[j];
}

/* events.illinois on guard j: the root's end where phi <= 0 (*t), the final bracket (*width) */
static void bm_illinois(bm_stepx *x, int j, double a, double fa, double b, double fb, double xtol, double *t,
                        double *width)
{
    int side = 0;
    for (int it = 0; it < 200; it++) {
        if (b - a <= xtol || fb == 0.0) break;
        double c;
        if (it % 3 == 2 || fa == fb) {
            c = 0.5 * (a + b);
        } else {
            c = (a * fb - b * fa) / (fb - fa);
            if (!(a < c && c < b)) c = 0.5 * (a + b);
        }
        double fc = bm_phi(x, j, c);
        if (fc > 0.0) {
            a = c; fa = fc;
            if (side == 1) fb *= 0.5;
            side = 1;
        } else {
            b = c; fb = fc;
            if (side == -1) fa *= 0.5;
            side = -1;
        }
    }
    *t = b;
    *width = fb == 0.0 ? 0.0 : b - a;
}

/* events._locate: 1 and (*t, *width) when guard j changes sign in [ta, tb] on the method's
 * own step, 0 when it does not there (the Hermite scan saw a crossing the step has not) */
static int bm_locate(bm_stepx *x, int j, double ta, double tb, double *t, double *width)
{
    double t0 = x->t0, xtol = x->ev->xtol;
    double fa = bm_phi(x, j, ta), fb = bm_phi(x, j, tb);
    if (!(fa > 0.0)) {
        ta = t0;
        fa = bm_phi(x, j, t0);
    }
    if (!(fa > 0.0) && fb <= 0.0) { /* armed at t0 without a positive value: where it is positive */
        for (int k = 1; k < 80; k++) {
            double tm = t0 + (tb - t0) * ldexp(1.0, -k);
            if (tm - t0 <= xtol) break;
            double fm = bm_phi(x, j, tm);
            if (fm > 0.0) {
                ta = tm; fa = fm;
                break;
            }
        }
    }
    if (!(fb <= 0.0)) {
        tb = x->t1;
        fb = bm_phi(x, j, x->t1);
    }
    if (!(fa > 0.0 && fb <= 0.0)) return 0;
    bm_illinois(x, j, ta, fa, tb, fb, xtol, t, width);
    return 1;
}

/* events._detect and the choice of events.integrate on one accepted step (t0, y0, f0) ->
 * (t1, y1, f1; f1 NULL: not computed by the method, RK4): 1 with the earliest event in ev */
static int bm_event_step(const bm_problem *P, const bm_tab *T, bm_rhs_fn rhs, const void *ctx, bm_events *ev,
                         double t0, const double *y0, const double *f0, double t1, const double *y1,
                         const double *f1)
{
    int ny = P->ny, ng = ev->ng, nh = 0, hj[BM_NG_MAX];
    double h = t1 - t0, f1c[BM_NYMAX], yk[BM_NYMAX], g[BM_NG_MAX], prev[BM_NG_MAX], ha[BM_NG_MAX], hb[BM_NG_MAX];
    if (!f1) {
        rhs(P, ctx, t1, y1, f1c);
        f1 = f1c;
    }
    for (int j = 0; j < ng; j++) prev[j] = t0;
    for (int k = 1; k <= ev->scan + 1 && !nh; k++) {
        double tk;
        if (k <= ev->scan) {
            tk = t0 + h * (double)k / (double)(ev->scan + 1);
            bm_hermite(ny, t0, y0, f0, t1, y1, f1, tk, yk);
        } else {
            tk = t1;
            memcpy(yk, y1, (size_t)ny * sizeof(double));
        }
        ev->G(ev->gctx, tk, yk, g);
        for (int j = 0; j < ng; j++) {
            if (g[j] > 0.0) {
                if (g[j] > ev->levels[j]) ev->armed[j] = 1;
                prev[j] = tk;
            } else if (ev->armed[j]) {
                hj[nh] = j; ha[nh] = prev[j]; hb[nh] = tk;
                nh++;
            }
        }
    }
    if (!nh) return 0;
    bm_stepx x = {P, T, rhs, ctx, t0, t1, y0, f0, y1, ev, {0}};
    int found = 0;
    for (int q = 0; q < nh; q++) {
        double te, w;
        if (bm_locate(&x, hj[q], ha[q], hb[q], &te, &w) && (!found || te < ev->t)) {
            found = 1;
            ev->j = hj[q];
            ev->t = te;
            ev->width = w;
        }
    }
    if (!found) return 0;
    bm_stepx_state(&x, ev->t, ev->y);
    ev->h_used = t1 - t0;
    return 1;
}

/* bm_advance, showing `seen` (when not NULL) every state a fixed-step run starts a step from,
 * and stopping at the first event of `ev` (when not NULL): returns 2 with the event in ev,
 * y_io and h_io unchanged */
static int bm_advance_seen(const bm_problem *P, const bm_tab *T, bm_rhs_fn rhs, const void *ctx, double t,
                           double *y_io, double t_end, double *h_io, bm_stats *st, bm_lerr *seen,
                           bm_events *ev)
{
    double K[(BM_NS_MAX + 1) * BM_NYMAX], y[BM_NYMAX], ynew[BM_NYMAX];
    size_t bytes = (size_t)P->ny * sizeof(double);
    double span = t_end - t;
    if (span <= 0.0) return 1;
    memcpy(y, y_io, bytes);
    rhs(P, ctx, t, y, K);
    st->nfev++;
    if (!bm_all_finite(K, P->ny)) return 0;
    int ns = P->ns;
    if (!P->adaptive) {
        double q = ceil(span / P->h_fixed - 1e-9);
        if (!(q <= (double)P->max_steps)) return 0; /* the work bound (Python raises StepFailure) */
        long long count = q < 1.0 ? 1 : (long long)q;
        double hh = span / (double)count;
        for (long long i = 0; i < count; i++) {
            double ti = t + (double)i * hh;
            if (i) {
                rhs(P, ctx, ti, y, K);
                st->nfev++;
            }
            if (seen) bm_lerr_see(seen, ti, y, K);
            bm_stages(P, T, rhs, ctx, ti, y, hh, K, ynew);
            st->nfev += ns - 1;
            if (!bm_all_finite(ynew, P->ny)) return 0;
            if (!bm_project(P, ynew)) return 0;
            st->steps++;
            if (ev && bm_event_step(P, T, rhs, ctx, ev, ti, y, K, i == count - 1 ? t_end : ti + hh, ynew, NULL))
                return 2;
            memcpy(y, ynew, bytes);
        }
        memcpy(y_io, y, bytes);
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
        bm_stages(P, T, rhs, ctx, t, y, hh, K, ynew);
        rhs(P, ctx, t + hh, ynew, BM_K(K, ns, P->ny));
        st->nfev += ns;
        double err = bm_error(P, T, K, hh, y, ynew);
        if (!(bm_all_finite(ynew, P->ny) && isfinite(err))) {
            st->rejected++;
            h = 0.2 * hh;
            if (!(h >= h_min_abs)) return 0;
            continue;
        }
        if (err <= 1.0) {
            double factor = err == 0.0 ? 10.0 : bm_pymin(10.0, 0.9 * pow(err, -1.0 / order));
            double t0 = t;
            t = last ? t_end : t + hh;
            if (!bm_project(P, ynew)) return 0;
            st->steps++;
            if (ev && bm_event_step(P, T, rhs, ctx, ev, t0, y, K, t, ynew, BM_K(K, ns, P->ny))) return 2;
            memcpy(y, ynew, bytes);
            memcpy(K, BM_K(K, ns, P->ny), bytes);
            h = last ? bm_pymax(h, hh * factor) : hh * factor;
        } else {
            st->rejected++;
            h = hh * bm_pymax(0.2, 0.9 * pow(err, -1.0 / order));
            if (!(h >= h_min_abs)) return 0;
        }
    }
    memcpy(y_io, y, bytes);
    *h_io = h;
    return 1;
}

/* ------------------------------------------------------------------ events.integrate
 * The one grid loop of the kernel's runs (events.integrate; a model without events is its
 * events.Plain): from grid point `start` (state y, step *h, mode *mode_io) over times[start..n-1],
 * integrating each interval with bm_advance_seen, handling the events of the current mode's
 * guards on the way (the system's map), recording every grid point reached (point `start`
 * itself only if record_start). Returns the index of the last point recorded: n - 1; or where
 * the system's record ends the run (a study's stop rule); or, with *status set, the point
 * before the interval that could not be done (1: a step failed; the caller redoes that
 * interval in Python, which reports the failure as it does) or where the system's map
 * stopped the run (its own status). *total: the work of the completed intervals. */
typedef struct bm_system bm_system;
struct bm_system {
    /* the mode's integrator problem, tableau, right-hand side and its context, and guards
     * (ev: zeroed before; ng = 0 none; armed[j] = 1 arms guard j although it is not positive) */
    void (*setup)(const bm_system *S, int mode, double t, const double *y, const bm_problem **P,
                  const bm_tab **T, bm_rhs_fn *rhs, const void **ctx, bm_events *ev);
    /* the map at the event in ev: the new mode, time, state and step; 0 ends the run (*status set) */
    int (*jump)(bm_system *S, int *mode, double *t, double *y, double *h, const bm_events *ev, int *status);
    /* grid point i reached (mode, state, the step to try next): record it; nonzero ends the run there */
    int (*record)(bm_system *S, long long i, int mode, double t, const double *y, double h);
    bm_lerr *seen; /* bm_advance_seen's run-error estimate (NULL: none) */
};

static long long bm_drive(bm_system *S, const double *times, long long n, long long start, int record_start,
                          int *mode_io, double *y, double *h, bm_stats *total, int *status)
{
    int mode = *mode_io;
    double t = times[start];
    long long last = n - 1;
    *status = 0;
    for (long long i = start; i < n; i++) {
        if (i > start) {
            bm_stats seg = {0, 0, 0};
            while (t < times[i]) {
                const bm_problem *P;
                const bm_tab *T;
                bm_rhs_fn rhs;
                const void *ctx;
                bm_events ev;
                memset(&ev, 0, sizeof ev);
                S->setup(S, mode, t, y, &P, &T, &rhs, &ctx, &ev);
                if (ev.ng) {
                    double g[BM_NG_MAX];
                    ev.G(ev.gctx, t, y, g);
                    for (int j = 0; j < ev.ng; j++) ev.armed[j] = ev.armed[j] || g[j] > ev.levels[j];
                }
                int code = bm_advance_seen(P, T, rhs, ctx, t, y, times[i], h, &seg, S->seen, ev.ng ? &ev : NULL);
                if (code == 0) {
                    *status = 1;
                    break;
                }
                if (code == 1) {
                    t = times[i];
                    continue;
                }
                if (!S->jump(S, &mode, &t, y, h, &ev, status)) break;
            }
            if (*status) {
                last = i - 1;
                break;
            }
            total->steps += seg.steps;
            total->rejected += seg.rejected;
            total->nfev += seg.nfev;
        } else if (!record_start) {
            continue;
        }
        if (S->record(S, i, mode, t, y, *h)) {
            last = i;
            break;
        }
    }
    *mode_io = mode;
    return last;
}

/* np.mean as numpy sums a short array: below 8 elements the first element, then the sum of
 * the rest; from 8 on numpy's pairwise sum (eight partial sums, combined in pairs, then the
 * elements left over) */
static inline double bm_np_mean(const double *a, int n)
{
    if (n >= 8) {
        double r[8];
        int i = 8;
        memcpy(r, a, sizeof r);
        for (; i < n - n % 8; i += 8)
            for (int j = 0; j < 8; j++) r[j] += a[i + j];
        double res = ((r[0] + r[1]) + (r[2] + r[3])) + ((r[4] + r[5]) + (r[6] + r[7]));
        for (; i < n; i++) res += a[i];
        return res / n;
    }
    double rest = 0.0;
    for (int i = 1; i < n; i++) rest += a[i];
    return (a[0] + rest) / n;
}

/* Integrator.initial_step (Hairer-Wanner) for any right-hand side, f0 = rhs(t, y) given,
 * with numpy's order of summation in its means, so it rounds as the Python does: the
 * native FMUs' starting step (ballinshell.c, inductionmotor.c). */
static inline double bm_initial_step_np(const bm_problem *P, bm_rhs_fn rhs, const void *ctx, double t,
                                        const double *y, const double *f0, double span)
{
    double sc[BM_NYMAX], q[BM_NYMAX], y1[BM_NYMAX] = {0}, f1[BM_NYMAX];
    int n = P->nerr > 0 ? P->nerr : P->ny; /* the controlled states (the means' length) */
    for (int i = 0; i < n; i++) sc[i] = P->tol * bm_pymax(fabs(y[i]), P->scale[i]) + P->tols[i];
    for (int i = 0; i < n; i++) q[i] = (y[i] / sc[i]) * (y[i] / sc[i]);
    double d0 = sqrt(bm_np_mean(q, n));
    for (int i = 0; i < n; i++) q[i] = (f0[i] / sc[i]) * (f0[i] / sc[i]);
    double d1 = sqrt(bm_np_mean(q, n));
    double h0 = (d0 < 1e-5 || d1 < 1e-5) ? 1e-6 : 0.01 * d0 / d1;
    h0 = bm_pymin(h0, span);
    for (int i = 0; i < P->ny; i++) y1[i] = y[i] + h0 * f0[i];
    rhs(P, ctx, t + h0, y1, f1);
    for (int i = 0; i < n; i++) q[i] = ((f1[i] - f0[i]) / sc[i]) * ((f1[i] - f0[i]) / sc[i]);
    double d2 = sqrt(bm_np_mean(q, n)) / h0;
    double h1 = (d1 <= 1e-15 && d2 <= 1e-15) ? bm_pymax(1e-6, h0 * 1e-3)
                                             : pow(0.01 / bm_pymax(d1, d2), 1.0 / P->order);
    return bm_pymin(bm_pymin(100 * h0, h1), P->h_max);
}

/* ------------------------------------------------------------------- model.py */
/* N of a state for the estimate: m (d |n'|^2 - a.n - g n_z), outputs.py's N with n''.n = -|n'|^2
 * (n a unit vector; the drag, along n', has no part along n), without the rest of the outputs */
static double bm_normal_force(const bm_problem *P, bm_mcache *c, double t, const double *y)
{
    double m[6];
    bm_motion_cached(P, c, t, m);
    double nx = y[0], ny = y[1], nz = y[2], wx = y[3], wy = y[4], wz = y[5], lam = P->o_lam;
    double ndx = lam * (ny * wz - nz * wy), ndy = lam * (nz * wx - nx * wz), ndz = lam * (nx * wy - ny * wx);
    return P->o_m * (P->o_d * (ndx * ndx + ndy * ndy + ndz * ndz) - m[4] * nx - m[5] * ny - P->o_g * nz);
}

/* simulate's loop from output point `start` (state y, step *h) over times[start..n-1]:
 * records ys[i] (and the outputs outs[i] unless outs is NULL) for every point reached
 * (point `start` itself only if record_start), adds the work of the completed intervals
 * to *total and returns the index of the last point reached; y and *h are then the state
 * there. For a point of a design study (ballmill.sweep's crank-kernel evaluator) two
 * additions that leave every recorded sample as it is:
 *  - err (not NULL; a fixed-step run from start = 0): the run's error estimated from the
 *    run itself (bm_lerr), over the samples recorded: err[0] for the contact point [m],
 *    err[1] for N [N]; limit > 0: the run ends at the first sample where err[0] exceeds it
 *    (its caller will redo the point with a smaller step: the rest would be wasted);
 *  - stop (stop != 0, with outs): after recording the first point where the model stops
 *    holding (not N > 0, or not friction_ratio <= mu: the rule of
 *    sweep.indicators.validity), the run ends there.
 * Below n - 1 without a stop, the run could not do the next interval: the caller redoes
 * the point on the ordinary path, which reports that failure as Python does. The platform
 * motion comes from a cache of the last times asked (the same values: bm_motion_cached). */
typedef struct {
    bm_system sys;
    const bm_problem *P;
    bm_tab T;
    bm_mcache cache;
    bm_lerr est;
    const double *times;
    int stop;
    double mu, limit, *ys, *outs;
} bm_study_sys;

static void bm_study_setup(const bm_system *S, int mode, double t, const double *y, const bm_problem **P,
                           const bm_tab **T, bm_rhs_fn *rhs, const void **ctx, bm_events *ev)
{
    const bm_study_sys *x = (const bm_study_sys *)S;
    (void)mode; (void)t; (void)y; (void)ev;
    *P = x->P;
    *T = &x->T;
    *rhs = bm_ball_rhs_cached;
    *ctx = &x->cache;
}

static int bm_study_record(bm_system *S, long long i, int mode, double t, const double *y, double h)
{
    bm_study_sys *x = (bm_study_sys *)S;
    double m[6];
    (void)mode; (void)t; (void)h;
    memcpy(x->ys + BM_NY * i, y, BM_NY * sizeof(double));
    if (S->seen && x->limit > 0.0 && x->est.err_P > x->limit) return 1;
    if (!x->outs) return 0;
    double *o = x->outs + BM_NOUT * i;
    bm_motion_cached(x->P, &x->cache, x->times[i], m);
    bm_outputs(x->P, y, m[4], m[5], m[0], m[1], o);
    return x->stop && !(o[9] > 0.0 && o[18] <= x->mu);
}

BM_EXPORT long long bm_simulate_study(const bm_problem *P, const double *times, long long n, long long start,
                                      int record_start, double *y, double *h, int stop, double mu, double *ys,
                                      double *outs, double *err, double limit, bm_stats *total)
{
    double f[BM_NY];
    bm_study_sys x;
    memset(&x, 0, sizeof x);
    x.sys.setup = bm_study_setup;
    x.sys.record = bm_study_record;
    x.P = P;
    x.est.P = P;
    x.est.cache = &x.cache;
    x.sys.seen = err && !P->adaptive && P->ny == BM_NY ? &x.est : NULL;
    x.times = times;
    x.stop = stop;
    x.mu = mu;
    x.limit = limit;
    x.ys = ys;
    x.outs = outs;
    bm_tab_make(P, &x.T);
    int mode = 0, status;
    long long last = bm_drive(&x.sys, times, n, start, record_start, &mode, y, h, total, &status);
    if (x.sys.seen) { /* the last state reached, seen with its derivative: the last interval's residual */
        bm_ball_rhs_cached(P, &x.cache, times[last], y, f);
        total->nfev++;
        bm_lerr_see(x.sys.seen, times[last], y, f);
        bm_lerr_end(x.sys.seen);
        err[0] = x.est.err_P;
        err[1] = x.est.err_N;
    }
    return last;
}

BM_EXPORT long long bm_simulate(const bm_problem *P, const double *times, long long n, long long start,
                                int record_start, double *y, double *h, double *ys, double *outs,
                                bm_stats *total)
{
    return bm_simulate_study(P, times, n, start, record_start, y, h, 0, 0.0, ys, outs, NULL, 0.0, total);
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
    if (!bm_advance(&Q, &T, bm_ball_rhs, NULL, io[0], y, io[1], &h, st)) return 0;
    io[2] = h;
    memcpy(io + 3, y, sizeof y);
    return 1;
}

/* Hairer-Wanner starting step as Integrator.initial_step (means summed left to
 * right). Not used by the library (fast.py takes Python's, whose numpy sums may
 * be ordered differently); the benchmark's standalone C peer needs one. */
BM_EXPORT double bm_initial_step(const bm_problem *P, double t, const double *y, double span)
{
    double sc[BM_NY], f0[BM_NY], f1[BM_NY], y1[BM_NY] = {0}, d0 = 0.0, d1 = 0.0, d2 = 0.0;
    int ny = P->ny;
    bm_rhs(P, t, y, f0);
    for (int i = 0; i < ny; i++) {
        double b = bm_pymax(fabs(y[i]), P->scale[i]);
        sc[i] = P->tol * b + P->tols[i];
        d0 += (y[i] / sc[i]) * (y[i] / sc[i]);
        d1 += (f0[i] / sc[i]) * (f0[i] / sc[i]);
    }
    d0 = sqrt(d0 / ny);
    d1 = sqrt(d1 / ny);
    double h0 = (d0 < 1e-5 || d1 < 1e-5) ? 1e-6 : 0.01 * d0 / d1;
    h0 = bm_pymin(h0, span);
    for (int i = 0; i < ny; i++) y1[i] = y[i] + h0 * f0[i];
    bm_rhs(P, t + h0, y1, f1);
    for (int i = 0; i < ny; i++) {
        double e = (f1[i] - f0[i]) / sc[i];
        d2 += e * e;
    }
    d2 = sqrt(d2 / ny) / h0;
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

/* ======================================================================
 * The general model: a chamber with any rigid motion (turning/model.py, turning/motions.py;
 * docs/design.md section 10). Functions bmg_*, reached through turning/kernel.py; they
 * run on the integrator above (bm_advance with the right-hand side bmg_rhs_cb, the
 * vector formulation's projection) but none of the translation-only functions' code
 * paths, which stay as they are.
 *
 *   n'     = (R/d) Omega x n + lambda n x omega
 *   omega' = k n x (a_A - g + R (Omega' x n + Omega x n') + r n' x omega)
 *
 * Motions: BMG_SPIN (motions.Spin), BMG_FIG1 (motions.Fig1Machine with the
 * angle laws CrankStartup or ConstantSpeed) and BMG_POLY (the chamber's motion over a communication
 * step as the BallInShell FMU reconstructs it, turning/reconstruction.py), in their operation order.
 * ====================================================================== */
enum { BMG_SPIN = 1, BMG_FIG1 = 2, BMG_POLY = 3 };
enum { BMG_LAW_CONST = 0, BMG_LAW_CRANK = 1 };
#define BMG_NCS 38  /* fields of motions.ChamberState */
#define BMG_NOUT 28 /* fields of turning.model.ChamberOutputs */
#define BMG_NPOLY 34 /* coefficients of the reconstruction's kin(t) (bmg_poly_kin) */

/* Everything a general run needs; filled by turning/kernel.py (ctypes mirror: _GProblem). */
typedef struct {
    bm_problem base; /* integrator settings, and form = BM_VECTOR, ny = BM_NY (bm_error and bm_project
                        read them); its motion and ball fields are not read */
    int kind;        /* BMG_SPIN, BMG_FIG1, BMG_POLY */
    double sp[10];   /* spin: Omega[3], A[3], axis[3], |Omega| */
    int frame_law, crank_law, parallel;
    double frame_p[2], crank_p[2]; /* const: w, angle0; crank: w0, t0 */
    double l, centre[3];
    double c[6];  /* turning.constants: R/d, lambda, R, r, g, k */
    double oc[10]; /* turning.out_constants: ... d, m, I, mu */
    /* BMG_POLY: ChamberReconstruction's fit: kin(t)'s coefficients (bmg_poly_kin), and state(t)'s
     * (bmg_poly_state): t0, the centre's quintics and Omega's cubics in s = t - t0, the newest Q */
    double poly[BMG_NPOLY], t0, pos[3][6], om[3][4], Q[9];
} bmg_problem;

/* drives.CrankStartup.angle / chamber.ConstantSpeed.angle */
static void bmg_law(int law, const double *p, double t, double a[3])
{
    if (law == BMG_LAW_CONST) {
        a[0] = p[1] + p[0] * t; a[1] = p[0]; a[2] = 0.0;
        return;
    }
    startup_angle(STARTUP_QUADRATIC, p[0], p[1], t, a);
}

/* Fig1Machine._kin: c, s, phi', phi'', psi', psi'' in k[0..5]; A, T, U */
static void bmg_fig1_kin(const bmg_problem *G, double t, double k[6], double A[3], double T[3], double U[3])
{
    double ph[3], ps[3], a[3], ap[3], app[3];
    bmg_law(G->frame_law, G->frame_p, t, ph);
    bmg_law(G->crank_law, G->crank_p, t, ps);
    double c = cos(ph[0]), s = sin(ph[0]);
    double cp = cos(ps[0]), sp = sin(ps[0]);
    double l = G->l, ox = G->centre[0], oy = G->centre[1], oz = G->centre[2];
    if (G->parallel) {
        a[0] = ox; a[1] = oy + l * cp; a[2] = oz + l * sp;
        ap[0] = 0.0; ap[1] = -l * sp; ap[2] = l * cp;
        app[0] = 0.0; app[1] = -l * cp; app[2] = -l * sp;
    } else {
        a[0] = ox + l * cp; a[1] = oy + l * sp; a[2] = oz;
        ap[0] = -l * sp; ap[1] = l * cp; ap[2] = 0.0;
        app[0] = -l * cp; app[1] = -l * sp; app[2] = 0.0;
    }
    A[0] = a[0]; A[1] = c * a[1] - s * a[2]; A[2] = s * a[1] + c * a[2];
    T[0] = ap[0]; T[1] = c * ap[1] - s * ap[2]; T[2] = s * ap[1] + c * ap[2];
    U[0] = app[0]; U[1] = c * app[1] - s * app[2]; U[2] = s * app[1] + c * app[2];
    k[0] = c; k[1] = s; k[2] = ph[1]; k[3] = ph[2]; k[4] = ps[1]; k[5] = ps[2];
}

/* Fig1Machine._acc */
static void bmg_fig1_acc(const double k[6], const double A[3], const double T[3], const double U[3],
                         double *aA)
{
    double phd = k[2], phdd = k[3], psd = k[4], psdd = k[5];
    aA[0] = psd * psd * U[0] + psdd * T[0];
    aA[1] = -phdd * A[2] - phd * phd * A[1] - 2.0 * phd * psd * T[2] + psd * psd * U[1] + psdd * T[1];
    aA[2] = phdd * A[1] - phd * phd * A[2] + 2.0 * phd * psd * T[1] + psd * psd * U[2] + psdd * T[2];
}

/* ---------------------------------------------------- turning/reconstruction.py
 * The chamber's motion over one communication step as the BallInShell FMU (motion = 2)
 * reconstructs it: ChamberReconstruction's kin(t) closure, its coefficients `poly`
 * (BMG_NPOLY: t0; a_A cubics x, y, z; Omega cubics; Omega' quadratics, in s = t - t0),
 * evaluated in the closure's operation order; and its state(t). */
static void bmg_poly_kin(const double *p, double t, double kin[9])
{
    double s = t - p[0];
    for (int k = 0; k < 3; k++) {
        const double *a = p + 1 + 4 * k, *o = p + 13 + 4 * k, *d = p + 25 + 3 * k;
        kin[k] = a[0] + s * (a[1] + s * (a[2] + s * a[3]));
        kin[3 + k] = o[0] + s * (o[1] + s * (o[2] + s * o[3]));
        kin[6 + k] = d[0] + s * (d[1] + s * d[2]);
    }
}

/* reconstruction.rotate: the rotation by theta (Rodrigues) times q, row-major */
static void bmg_rotate(const double th3[3], const double *q, double *out)
{
    double tx = th3[0], ty = th3[1], tz = th3[2];
    double th = sqrt(tx * tx + ty * ty + tz * tz);
    if (th == 0.0) {
        memcpy(out, q, 9 * sizeof(double));
        return;
    }
    double ex = tx / th, ey = ty / th, ez = tz / th;
    double c = cos(th), s = sin(th);
    double u = 1.0 - c;
    double m[9] = {c + u * ex * ex, u * ex * ey - s * ez, u * ex * ez + s * ey,
                   u * ey * ex + s * ez, c + u * ey * ey, u * ey * ez - s * ex,
                   u * ez * ex - s * ey, u * ez * ey + s * ex, c + u * ez * ez};
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) out[3 * i + j] = (m[3 * i] * q[j] + m[3 * i + 1] * q[3 + j]) + m[3 * i + 2] * q[6 + j];
}

/* ChamberReconstruction.state: the 38 fields of a ChamberState at t (drive fields 0) of the fit
 * (t0, the centre's quintics pos, Omega's cubics om, the newest Q) */
static void bmg_poly_state(double t0, const double pos[3][6], const double om[3][4], const double *Q, double t,
                           double *cs)
{
    double s = t - t0, th[3];
    memset(cs, 0, BMG_NCS * sizeof(double));
    for (int k = 0; k < 3; k++) {
        const double *p = pos[k], *o = om[k];
        cs[k] = p[0] + s * (p[1] + s * (p[2] + s * (p[3] + s * (p[4] + s * p[5]))));
        cs[3 + k] = p[1] + s * (2.0 * p[2] + s * (3.0 * p[3] + s * (4.0 * p[4] + s * (5.0 * p[5]))));
        cs[6 + k] = 2.0 * p[2] + s * (6.0 * p[3] + s * (12.0 * p[4] + s * (20.0 * p[5])));
        cs[9 + k] = o[0] + s * (o[1] + s * (o[2] + s * o[3]));
        cs[12 + k] = o[1] + s * (2.0 * o[2] + s * (3.0 * o[3]));
        th[k] = s * (o[0] + s * (0.5 * o[1] + s * (o[2] / 3.0 + s * (0.25 * o[3]))));
    }
    bmg_rotate(th, Q, cs + 15);
}

/* ChamberMotion.accel: a_A, Omega, Omega' */
static void bmg_accel(const bmg_problem *G, double t, double kin[9])
{
    if (G->kind == BMG_POLY) {
        bmg_poly_kin(G->poly, t, kin);
        return;
    }
    if (G->kind == BMG_SPIN) {
        kin[0] = 0.0; kin[1] = 0.0; kin[2] = 0.0;
        kin[3] = G->sp[0]; kin[4] = G->sp[1]; kin[5] = G->sp[2];
        kin[6] = 0.0; kin[7] = 0.0; kin[8] = 0.0;
        return;
    }
    double k[6], A[3], T[3], U[3];
    bmg_fig1_kin(G, t, k, A, T, U);
    bmg_fig1_acc(k, A, T, U, kin);
    kin[3] = k[2]; kin[4] = 0.0; kin[5] = 0.0;
    kin[6] = k[3]; kin[7] = 0.0; kin[8] = 0.0;
}

/* ChamberMotion.state: the 38 fields of ChamberState */
static void bmg_state(const bmg_problem *G, double t, double *cs)
{
    if (G->kind == BMG_POLY) {
        bmg_poly_state(G->t0, G->pos, G->om, G->Q, t, cs);
        return;
    }
    memset(cs, 0, BMG_NCS * sizeof(double));
    if (G->kind == BMG_SPIN) { /* Spin.state */
        const double *p = G->sp;
        double ex = p[6], ey = p[7], ez = p[8];
        double ax = p[3], ay = p[4], az = p[5];
        double th = p[9] * t;
        double c = cos(th), s = sin(th);
        double u = 1.0 - c;
        cs[0] = ax; cs[1] = ay; cs[2] = az;
        cs[9] = p[0]; cs[10] = p[1]; cs[11] = p[2];
        cs[15] = c + u * ex * ex; cs[16] = u * ex * ey - s * ez; cs[17] = u * ex * ez + s * ey;
        cs[18] = u * ey * ex + s * ez; cs[19] = c + u * ey * ey; cs[20] = u * ey * ez - s * ex;
        cs[21] = u * ez * ex - s * ey; cs[22] = u * ez * ey + s * ex; cs[23] = c + u * ez * ez;
        cs[24] = p[9];
        cs[25] = ex; cs[26] = ey; cs[27] = ez;
        cs[28] = ay * ez - az * ey; cs[29] = az * ex - ax * ez; cs[30] = ax * ey - ay * ex;
        return;
    }
    double k[6], A[3], T[3], U[3];
    bmg_fig1_kin(G, t, k, A, T, U);
    double phd = k[2], psd = k[4];
    cs[0] = A[0]; cs[1] = A[1]; cs[2] = A[2];
    cs[3] = psd * T[0]; cs[4] = -phd * A[2] + psd * T[1]; cs[5] = phd * A[1] + psd * T[2];
    bmg_fig1_acc(k, A, T, U, cs + 6);
    cs[9] = phd; cs[12] = k[3];
    cs[15] = 1.0; cs[19] = k[0]; cs[20] = -k[1]; cs[22] = k[1]; cs[23] = k[0];
    cs[24] = phd; cs[25] = 1.0;
    cs[31] = psd; cs[35] = T[0]; cs[36] = T[1]; cs[37] = T[2];
}

/* turning.derivative */
static void bmg_derivative(const double *c, const double *y, const double *kin, double *f)
{
    double nx = y[0], ny = y[1], nz = y[2], wx = y[3], wy = y[4], wz = y[5];
    double Rd = c[0], lam = c[1], R = c[2], r = c[3], g = c[4], k = c[5];
    double ax = kin[0], ay = kin[1], az = kin[2], ox = kin[3], oy = kin[4], oz = kin[5];
    double px = kin[6], py = kin[7], pz = kin[8];
    double ndx = Rd * (oy * nz - oz * ny) + lam * (ny * wz - nz * wy);
    double ndy = Rd * (oz * nx - ox * nz) + lam * (nz * wx - nx * wz);
    double ndz = Rd * (ox * ny - oy * nx) + lam * (nx * wy - ny * wx);
    double bx = ax + R * ((py * nz - pz * ny) + (oy * ndz - oz * ndy)) + r * (ndy * wz - ndz * wy);
    double by = ay + R * ((pz * nx - px * nz) + (oz * ndx - ox * ndz)) + r * (ndz * wx - ndx * wz);
    double bz = (az + g) + R * ((px * ny - py * nx) + (ox * ndy - oy * ndx)) + r * (ndx * wy - ndy * wx);
    f[0] = ndx; f[1] = ndy; f[2] = ndz;
    f[3] = k * (ny * bz - nz * by);
    f[4] = k * (nz * bx - nx * bz);
    f[5] = k * (nx * by - ny * bx);
}

static void bmg_rhs(const bmg_problem *G, double t, const double *y, double *f)
{
    double kin[9];
    bmg_accel(G, t, kin);
    bmg_derivative(G->c, y, kin, f);
}

/* turning.evaluate_c: the 28 fields of ChamberOutputs */
static void bmg_outputs(const double *c, const double *y, const double *cs, double *o)
{
    double nx = y[0], ny = y[1], nz = y[2], wx = y[3], wy = y[4], wz = y[5];
    /* Ib, not I: <complex.h> (which the native induction motor FMU includes first) makes I a macro */
    double Rd = c[0], lam = c[1], R = c[2], g = c[4], d = c[6], m = c[7], Ib = c[8], mu = c[9];
    double Ax = cs[0], Ay = cs[1], Az = cs[2], vAx = cs[3], vAy = cs[4], vAz = cs[5];
    double ax = cs[6], ay = cs[7], az = cs[8], ox = cs[9], oy = cs[10], oz = cs[11];
    double px = cs[12], py = cs[13], pz = cs[14];
    const double *q = cs + 15;
    const double *w1 = cs + 25, *v1 = cs + 28, *w2 = cs + 32, *v2 = cs + 35;
    double f[6]; /* n', omega': the right-hand side, with cs[6..14] = (a_A, Omega, Omega') as kin */
    bmg_derivative(c, y, cs + 6, f);
    double ndx = f[0], ndy = f[1], ndz = f[2], wdx = f[3], wdy = f[4], wdz = f[5];
    double nddx = Rd * ((py * nz - pz * ny) + (oy * ndz - oz * ndy))
                  + lam * (ndy * wz - ndz * wy + ny * wdz - nz * wdy);
    double nddy = Rd * ((pz * nx - px * nz) + (oz * ndx - ox * ndz))
                  + lam * (ndz * wx - ndx * wz + nz * wdx - nx * wdz);
    double nddz = Rd * ((px * ny - py * nx) + (ox * ndy - oy * ndx))
                  + lam * (ndx * wy - ndy * wx + nx * wdy - ny * wdx);
    double Fx = m * (ax + d * nddx);
    double Fy = m * (ay + d * nddy);
    double Fz = m * ((az + d * nddz) + g);
    double N = -(Fx * nx + Fy * ny + Fz * nz);
    double ftx = Fx + N * nx, fty = Fy + N * ny, ftz = Fz + N * nz;
    double Ft = sqrt(ftx * ftx + fty * fty + ftz * ftz);
    int contact = N > 0.0;
    double sx = -Fx, sy = -Fy, sz = -Fz;
    double Px = Ax + R * nx, Py = Ay + R * ny, Pz = Az + R * nz;
    double mx = Py * sz - Pz * sy, my = Pz * sx - Px * sz, mz = Px * sy - Py * sx;
    double M1 = (w1[0] * mx + w1[1] * my + w1[2] * mz) + (v1[0] * sx + v1[1] * sy + v1[2] * sz);
    double M2 = (w2[0] * mx + w2[1] * my + w2[2] * mz) + (v2[0] * sx + v2[1] * sy + v2[2] * sz);
    double vpx = vAx + R * (oy * nz - oz * ny);
    double vpy = vAy + R * (oz * nx - ox * nz);
    double vpz = vAz + R * (ox * ny - oy * nx);
    double vcx = vAx + d * ndx, vcy = vAy + d * ndy, vcz = vAz + d * ndz;
    double E = 0.5 * m * (vcx * vcx + vcy * vcy + vcz * vcz) + 0.5 * Ib * (wx * wx + wy * wy + wz * wz)
               + m * g * (Az + d * nz);
    o[0] = Px; o[1] = Py; o[2] = Pz;
    o[3] = R * (q[0] * nx + q[3] * ny + q[6] * nz);
    o[4] = R * (q[1] * nx + q[4] * ny + q[7] * nz);
    o[5] = R * (q[2] * nx + q[5] * ny + q[8] * nz) + R;
    o[6] = Ax + d * nx; o[7] = Ay + d * ny; o[8] = Az + d * nz;
    o[9] = wx; o[10] = wy; o[11] = wz;
    o[12] = nx * wx + ny * wy + nz * wz;
    o[13] = N; o[14] = Ft; o[15] = contact ? Ft / N : INFINITY;
    o[16] = sx; o[17] = sy; o[18] = sz;
    o[19] = q[0] * sx + q[3] * sy + q[6] * sz;
    o[20] = q[1] * sx + q[4] * sy + q[7] * sz;
    o[21] = q[2] * sx + q[5] * sy + q[8] * sz;
    o[22] = M1; o[23] = M2;
    o[24] = Fx * vpx + Fy * vpy + Fz * vpz;
    o[25] = E;
    o[26] = contact ? 1.0 : 0.0;
    o[27] = (contact && Ft <= mu * N) ? 1.0 : 0.0;
}

/* the general right-hand side as an integrator calls it (ctx: the bmg_problem) */
static void bmg_rhs_cb(const bm_problem *P, const void *ctx, double t, const double *y, double *f)
{
    (void)P;
    bmg_rhs(ctx, t, y, f);
}

/* turning.simulate_general's loop, as bm_simulate (same contract; outputs: 28 per point), on bm_drive */
typedef struct {
    bm_system sys;
    const bmg_problem *G;
    bm_tab T;
    const double *times;
    double *ys, *outs;
} bmg_sim_sys;

static void bmg_sim_setup(const bm_system *S, int mode, double t, const double *y, const bm_problem **P,
                          const bm_tab **T, bm_rhs_fn *rhs, const void **ctx, bm_events *ev)
{
    const bmg_sim_sys *x = (const bmg_sim_sys *)S;
    (void)mode; (void)t; (void)y; (void)ev;
    *P = &x->G->base;
    *T = &x->T;
    *rhs = bmg_rhs_cb;
    *ctx = x->G;
}

static int bmg_sim_record(bm_system *S, long long i, int mode, double t, const double *y, double h)
{
    bmg_sim_sys *x = (bmg_sim_sys *)S;
    double cs[BMG_NCS];
    (void)mode; (void)t; (void)h;
    memcpy(x->ys + BM_NY * i, y, BM_NY * sizeof(double));
    if (x->outs) {
        bmg_state(x->G, x->times[i], cs);
        bmg_outputs(x->G->oc, y, cs, x->outs + BMG_NOUT * i);
    }
    return 0;
}

BM_EXPORT long long bmg_simulate(const bmg_problem *G, const double *times, long long n, long long start,
                                 int record_start, double *y, double *h, double *ys, double *outs,
                                 bm_stats *total)
{
    bmg_sim_sys x;
    memset(&x, 0, sizeof x);
    x.sys.setup = bmg_sim_setup;
    x.sys.record = bmg_sim_record;
    x.G = G;
    x.times = times;
    x.ys = ys;
    x.outs = outs;
    bm_tab_make(&G->base, &x.T);
    int mode = 0, status;
    return bm_drive(&x.sys, times, n, start, record_start, &mode, y, h, total, &status);
}

/* the general right-hand side along a reconstructed motion: ctx = {constants c[6], poly} */
typedef struct {
    const double *c, *poly;
} bmg_poly_ctx;

static void bmg_poly_rhs(const bm_problem *P, const void *ctx, double t, const double *y, double *f)
{
    const bmg_poly_ctx *x = ctx;
    double kin[9];
    (void)P;
    bmg_poly_kin(x->poly, t, kin);
    bmg_derivative(x->c, y, kin, f);
}

/* ChamberModel.advance along a reconstructed motion (the pythonfmu BallInShell with
 * motion = 2), as bm_advance_interval: io = t, t_end, h, y[6], poly[BMG_NPOLY]; on
 * success (1) io[2] and io[3..8] hold the next step and the state at t_end; 0: Python
 * must do the interval (it fails there, or needs the initial step); io is then unchanged. */
BM_EXPORT int bmg_advance_poly(const bmg_problem *G, double *io, bm_stats *st)
{
    bm_tab T;
    double y[BM_NY], h = io[2];
    bmg_poly_ctx ctx = {G->c, io + 3 + BM_NY};
    bm_tab_make(&G->base, &T);
    memcpy(y, io + 3, sizeof y);
    st->steps = 0; st->rejected = 0; st->nfev = 0;
    if (!bm_advance(&G->base, &T, bmg_poly_rhs, &ctx, io[0], y, io[1], &h, st)) return 0;
    io[2] = h;
    memcpy(io + 3, y, sizeof y);
    return 1;
}

/* single evaluations, for tests and the benchmark */
BM_EXPORT void bmg_eval_rhs(const bmg_problem *G, double t, const double *y, double *f) { bmg_rhs(G, t, y, f); }
BM_EXPORT void bmg_eval_state(const bmg_problem *G, double t, double *cs) { bmg_state(G, t, cs); }
BM_EXPORT void bmg_eval_outputs(const bmg_problem *G, const double *y, const double *cs, double *o)
{
    bmg_outputs(G->oc, y, cs, o);
}
BM_EXPORT size_t bmg_problem_size(void) { return sizeof(bmg_problem); }

/* ======================================================================
 * The ball absorber: a modal structure carrying the cavity and the ball rolling in it,
 * in one ODE (ballmill/absorber/model.py StructureBall.rhs; structure.py StructureModel,
 * HarmonicForce, HarmonicGround; docs/design.md section 11). Functions bma_*, reached through
 * ballmill/absorber/kernel.py. State: the structure (q_x[nx], q_x'[nx], q_y[ny], q_y'[ny]),
 * the ball (n, omega), the quadratures (W_exc, W_damp, W_ball). The cavity's acceleration
 * is solved with the ball's load at each instant (the 2x2 system of model.py, on the
 * rolling-resistance branch that is consistent). Written in the Python code's operation
 * order; integrated by bm_advance (form BM_ABSORBER: the projection of n).
 * ====================================================================== */
#define BMA_MODES 4                   /* modes per axis, at most */
#define BMA_NY (4 * BMA_MODES + 9)     /* states, at most (BM_NYMAX is this) */
#define BMA_PI 3.141592653589793       /* math.pi */

/* Everything a run needs; filled by absorber/kernel.py (ctypes mirror: _AProblem). */
typedef struct {
    bm_problem base; /* the integrator's settings: tableau, tol, h_fixed, h_max, max_steps, scale,
                        tols, form = BM_ABSORBER, ny = 2 (nm[0] + nm[1]) + 9 */
    int nm[2];       /* modes of the x and y axes (0: the axis does not move) */
    double mode[2][BMA_MODES][6]; /* per mode: M, K, C, phi, psi, L */
    double G[2];     /* flexibility of each axis: sum phi^2 / M */
    int ground;      /* 0: a harmonic force, 1: a harmonic ground acceleration */
    double exc[7];   /* amplitude_x, frequency, amplitude_y, phase, phase_y, sweep_rate, t0 */
    double c[7];     /* lambda, r, g, k, m, d, r k (StructureBall._c) */
    int lossy;       /* drag or rolling resistance */
    double delta, J, drag, eps2;
    double loss_nr[9]; /* loss constants without the rolling resistance (StructureBall._loss_nr) */
    double loss[9];    /* equations.loss_constants (the formulation's lossy derivative) */
} bma_problem;

/* excitation.loads(t): (F_x, F_y, a_gx, a_gy) */
static void bma_loads(const bma_problem *A, double t, double L[4])
{
    const double *e = A->exc;
    double s = t - e[6];
    double th = e[3] + 2.0 * BMA_PI * s * (e[1] + 0.5 * e[5] * s);
    double x = e[0] * sin(th), y = e[2] * sin(th + e[4]);
    L[0] = A->ground ? 0.0 : x;
    L[1] = A->ground ? 0.0 : y;
    L[2] = A->ground ? x : 0.0;
    L[3] = A->ground ? y : 0.0;
}

/* StructureModel.free_acceleration: a_free per axis and each mode's acceleration without the ball */
static void bma_free(const bma_problem *A, const double *z, const double L[4], double a0[2],
                     double rr[2][BMA_MODES])
{
    int off = 0;
    for (int ax = 0; ax < 2; ax++) {
        int n = A->nm[ax];
        double F = L[ax], g = L[2 + ax], a = g;
        for (int j = 0; j < n; j++) {
            const double *md = A->mode[ax][j]; /* M, K, C, phi, psi, L */
            double rj = (md[4] * F - md[5] * g - md[2] * z[off + n + j] - md[1] * z[off + j]) / md[0];
            rr[ax][j] = rj;
            a += md[3] * rj;
        }
        a0[ax] = a;
        off += 2 * n;
    }
}

/* StructureBall._load_affine: F_b = F0 + B a_O (horizontal), rolling resistance on or off */
static void bma_load_affine(const bma_problem *A, const double *n, const double *w, const double *nd,
                            int branch_rr, double o[6])
{
    double lam = A->c[0], r = A->c[1], g = A->c[2], k = A->c[3], m = A->c[4], d = A->c[5], rk = A->c[6];
    double nx = n[0], ny = n[1], nz = n[2], wx = w[0], wy = w[1], wz = w[2];
    double ndx = nd[0], ndy = nd[1], ndz = nd[2], wd[3];
    (void)lam;
    if (A->lossy) {
        bm_omega_dot_lossy(A->loss_nr, nx, ny, nz, wx, wy, wz, ndx, ndy, ndz, 0.0, 0.0, NULL, wd);
    } else {
        bm_omega_dot(k, r, g, nx, ny, nz, wx, wy, wz, ndx, ndy, ndz, 0.0, 0.0, wd);
    }
    double wdx = wd[0], wdy = wd[1], wdz = wd[2], rho = 0.0;
    if (branch_rr) {
        double s = nx * wx + ny * wy + nz * wz;
        double tx = wx - s * nx, ty = wy - s * ny, tz = wz - s * nz;
        double sq = sqrt(tx * tx + ty * ty + tz * tz + A->eps2);
        double N0 = m * (d * (ndx * ndx + ndy * ndy + ndz * ndz) - g * nz);
        double f = -A->delta * N0 / (A->J * sq);
        wdx = wdx + f * tx;
        wdy = wdy + f * ty;
        wdz = wdz + f * tz;
        rho = d * A->delta * m / (A->J * sq);
    }
    o[0] = -m * r * (ndy * wz - ndz * wy + ny * wdz - nz * wdy);
    o[1] = -m * r * (ndz * wx - ndx * wz + nz * wdx - nx * wdz);
    double c1 = 1.0 - rk;
    o[2] = -m * (c1 + rk * nx * nx + rho * ndx * nx);
    o[3] = -m * (rk * nx * ny + rho * ndx * ny);
    o[4] = -m * (rk * ny * nx + rho * ndy * nx);
    o[5] = -m * (c1 + rk * ny * ny + rho * ndy * ny);
}

/* StructureBall.rhs */
static void bma_rhs(const bma_problem *A, double t, const double *z, double *dz)
{
    double L[4], a0[2], rr[2][BMA_MODES], F[6];
    int ns = A->base.ny - 9, ib = ns;
    const double *n = z + ib, *w = z + ib + 3;
    double lam = A->c[0], r = A->c[1], g = A->c[2], m = A->c[4], d = A->c[5];
    double nd[3] = {lam * (n[1] * w[2] - n[2] * w[1]), lam * (n[2] * w[0] - n[0] * w[2]),
                    lam * (n[0] * w[1] - n[1] * w[0])};
    bma_loads(A, t, L);
    bma_free(A, z, L, a0, rr);
    /* StructureBall._solve */
    double Gx = A->G[0], Gy = A->G[1], ax = 0.0, ay = 0.0;
    int nb = A->delta != 0.0 ? 2 : 1;
    for (int b = 0; b < nb; b++) {
        int branch = nb == 2 && b == 0;
        bma_load_affine(A, n, w, nd, branch, F);
        double a11 = 1.0 - Gx * F[2], a12 = -Gx * F[3];
        double a21 = -Gy * F[4], a22 = 1.0 - Gy * F[5];
        double b1 = a0[0] + Gx * F[0], b2 = a0[1] + Gy * F[1];
        double det = a11 * a22 - a12 * a21;
        ax = (b1 * a22 - a12 * b2) / det;
        ay = (a11 * b2 - a21 * b1) / det;
        if (nb == 1) break;
        double N = m * (d * (bm_sq(nd[0]) + bm_sq(nd[1]) + bm_sq(nd[2])) - ax * n[0] - ay * n[1] - g * n[2]);
        if ((N > 0.0) == branch) break;
    }
    /* the ball's derivative (VectorFormulation.derivative / _derivative_lossy) at a_O */
    double *db = dz + ib;
    {
        double nx = n[0], ny = n[1], nz = n[2], wx = w[0], wy = w[1], wz = w[2];
        double ndx = lam * (ny * wz - nz * wy);
        double ndy = lam * (nz * wx - nx * wz);
        double ndz = lam * (nx * wy - ny * wx);
        db[0] = ndx; db[1] = ndy; db[2] = ndz;
        if (A->lossy) {
            bm_omega_dot_lossy(A->loss, nx, ny, nz, wx, wy, wz, ndx, ndy, ndz, ax, ay, NULL, db + 3);
        } else {
            bm_omega_dot(A->c[3], r, g, nx, ny, nz, wx, wy, wz, ndx, ndy, ndz, ax, ay, db + 3);
        }
    }
    double wdx = db[3], wdy = db[4], wdz = db[5];
    double Fb[2];
    Fb[0] = -m * (ax + r * (nd[1] * w[2] - nd[2] * w[1] + n[1] * wdz - n[2] * wdy));
    Fb[1] = -m * (ay + r * (nd[2] * w[0] - nd[0] * w[2] + n[2] * wdx - n[0] * wdz));
    /* the structure: q' and q'' = r_j + phi_j F_b / M_j; the powers (StructureModel.powers) */
    double P_exc = 0.0, P_damp = 0.0, vel[2] = {0.0, 0.0};
    int off = 0;
    for (int a = 0; a < 2; a++) {
        int nm = A->nm[a];
        for (int j = 0; j < nm; j++) {
            const double *md = A->mode[a][j];
            dz[off + j] = z[off + nm + j];
            dz[off + nm + j] = rr[a][j] + md[3] * Fb[a] / md[0];
        }
        for (int j = 0; j < nm; j++) {
            const double *md = A->mode[a][j];
            double qd = z[off + nm + j];
            P_exc += qd * (md[4] * L[a] - md[5] * L[2 + a]);
            P_damp += md[2] * qd * qd;
            vel[a] = j ? vel[a] + md[3] * qd : md[3] * qd; /* Python's sum(): 0 + first = first */
        }
        off += 2 * nm;
    }
    /* the ground's inertial load on the ball, -m a_g . v_C (relative to the ground) */
    if (L[2] != 0.0 || L[3] != 0.0)
        P_exc -= m * (L[2] * (vel[0] + d * nd[0]) + L[3] * (vel[1] + d * nd[1]));
    dz[ns + 6] = P_exc;
    dz[ns + 7] = P_damp;
    double Pb = 0.0;
    if (A->lossy) { /* StructureBall._ball_dissipation */
        double nd2 = bm_sq(nd[0]) + bm_sq(nd[1]) + bm_sq(nd[2]);
        Pb = A->drag * d * d * nd2;
        if (A->delta != 0.0) {
            double N = m * (d * nd2 - ax * n[0] - ay * n[1] - g * n[2]);
            if (N > 0.0) {
                double s = n[0] * w[0] + n[1] * w[1] + n[2] * w[2];
                double e0 = w[0] - s * n[0], e1 = w[1] - s * n[1], e2 = w[2] - s * n[2];
                double t2 = bm_sq(e0) + bm_sq(e1) + bm_sq(e2);
                Pb += A->delta * N * t2 / sqrt(t2 + A->eps2);
            }
        }
    }
    dz[ns + 8] = Pb;
}

/* the absorber's right-hand side as an integrator calls it (ctx: the bma_problem) */
static void bma_rhs_cb(const bm_problem *P, const void *ctx, double t, const double *z, double *dz)
{
    (void)P;
    bma_rhs(ctx, t, z, dz);
}

/* simulate_absorber's loop over output points times[1..n-1] from the state y (at times[0])
 * with step *h: ys[i] for every point reached; returns the index of the last point reached
 * (y and *h are the state and step there; *total the work). Stops at the first interval
 * it cannot complete (Python redoes that one). On bm_drive. */
typedef struct {
    bm_system sys;
    const bma_problem *A;
    bm_tab T;
    double *ys;
} bma_sim_sys;

static void bma_sim_setup(const bm_system *S, int mode, double t, const double *y, const bm_problem **P,
                          const bm_tab **T, bm_rhs_fn *rhs, const void **ctx, bm_events *ev)
{
    const bma_sim_sys *x = (const bma_sim_sys *)S;
    (void)mode; (void)t; (void)y; (void)ev;
    *P = &x->A->base;
    *T = &x->T;
    *rhs = bma_rhs_cb;
    *ctx = x->A;
}

static int bma_sim_record(bm_system *S, long long i, int mode, double t, const double *y, double h)
{
    bma_sim_sys *x = (bma_sim_sys *)S;
    size_t ny = (size_t)x->A->base.ny;
    (void)mode; (void)t; (void)h;
    memcpy(x->ys + ny * (size_t)i, y, ny * sizeof(double));
    return 0;
}

BM_EXPORT long long bma_simulate(const bma_problem *A, const double *times, long long n, double *y, double *h,
                                 double *ys, bm_stats *total)
{
    bma_sim_sys x;
    memset(&x, 0, sizeof x);
    x.sys.setup = bma_sim_setup;
    x.sys.record = bma_sim_record;
    x.A = A;
    x.ys = ys;
    bm_tab_make(&A->base, &x.T);
    int mode = 0, status;
    return bm_drive(&x.sys, times, n, 0, 0, &mode, y, h, total, &status);
}

BM_EXPORT void bma_eval_rhs(const bma_problem *A, double t, const double *z, double *dz) { bma_rhs(A, t, z, dz); }
BM_EXPORT int bma_eval_project(const bma_problem *A, double *z) { return bm_project(&A->base, z); }
BM_EXPORT size_t bma_problem_size(void) { return sizeof(bma_problem); }

/* ======================================================================
 * The hybrid ball: rolling, sliding, flight and impacts in a translating or a turning
 * chamber (hybrid.py HybridBall on events.integrate; docs/design.md section 14). Functions
 * bmh_*, reached through fast.py (`hybrid_run`). Rolling is the vector formulation above
 * (translation) or the general model's bmg_* (turning), state n, omega, and with `energy` the
 * quadratures W, E_friction, then Lq (the torque's quadrature, outside the error norm: nerr);
 * sliding and flight carry (C, v_C, omega, W, E_friction, Lq) in fixed axes. The modes' right-hand sides, guards and maps are written in hybrid.py's operation
 * order (a translating chamber's Omega = 0 carried through its expressions, as the Python
 * has it), and the grid loop with its events is
 * events.integrate's, on bm_advance_seen's event location: the same floats, events and
 * bookkeeping as the Python run.
 * ====================================================================== */
enum { BMH_FLIGHT = 0, BMH_ROLLING = 1, BMH_SLIDING = 2 };
enum { BMH_SLIP = 0, BMH_LEAVE = 1, BMH_STICK = 2, BMH_IMPACT = 3 }; /* event kinds */
#define BMH_NZ 12   /* a free state: C, v_C, omega, W, E_friction, Lq */
#define BMH_NCOL 26 /* HybridBall.COLUMNS */
#define BMH_NEV 18  /* doubles of an event record (hybrid_run's EVENT_FIELDS) */
#define BMH_NBOOK 14 /* E_impact, n_impacts, v_impact_max, t_first_slip, t_first_flight, Q[2], seed[3], rebound,
                        W_lost, t_held, held_window (HybridBall.BOOK) */
#define BMH_BOOK_T_HELD 12      /* the book's t_held (NAN: not held) and held_window */
#define BMH_BOOK_HELD_WINDOW 13

/* Everything a hybrid run needs; filled by fast.py (ctypes mirror: _HProblem). */
typedef struct {
    bm_problem roll; /* the rolling mode: motion, ball, integrator of ny = 7 (9 with energy; the last, Lq,
                        outside the error norm), form BM_VECTOR (turning: its integrator part only) */
    int turning;     /* 0: the translating chamber of roll's motion; 1: gen's turning chamber */
    bmg_problem gen; /* turning: the chamber motion and the general model's constants */
    bm_problem free; /* sliding and flight: the integrator of ny = 12 (nerr = 11), form BM_GENERIC */
    double R, r, d, m, g, Ib, lam, /* Ib, not I: <complex.h> makes I a macro */
           mu, mu_k, e_n, v_rest, slip_eps, kt, gap_res, creep_eps;
    int energy;
    int scan, burst;
    double xtol, max_rate;
    int zeno_hold; /* the Zeno guard: 0 stops the run (status 2), 1 holds the ball on the wall (bmh_hold) */
} bmh_problem;

/* the run's bookkeeping (HybridBall.book, _seed, _rebound) */
typedef struct {
    const bmh_problem *H;
    double E_impact, n_impacts, v_impact_max, t_first_slip, t_first_flight, Q[2];
    double seed[3];
    int rebound;
    int w_lost; /* rolling without the work quadrature happened: W_chamber is NaN from there on */
    double t_held, held_window; /* HybridBall.hold: the Zeno stop the ball is held from, the burst's span; NAN: not */
} bmh_run;

static void bmh_cross(const double *a, const double *b, double *c)
{
    c[0] = a[1] * b[2] - a[2] * b[1];
    c[1] = a[2] * b[0] - a[0] * b[2];
    c[2] = a[0] * b[1] - a[1] * b[0];
}

static double bmh_dot(const double *a, const double *b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }

/* HybridBall.chamber: A, v_A, a_A, Omega, Omega' (Omd: NULL when not needed) */
static void bmh_chamber(const bmh_problem *H, double t, double *A, double *vA, double *aA, double *Om, double *Omd)
{
    if (H->turning) {
        double cs[BMG_NCS];
        bmg_state(&H->gen, t, cs);
        memcpy(A, cs, 3 * sizeof(double));
        memcpy(vA, cs + 3, 3 * sizeof(double));
        memcpy(aA, cs + 6, 3 * sizeof(double));
        memcpy(Om, cs + 9, 3 * sizeof(double));
        if (Omd) memcpy(Omd, cs + 12, 3 * sizeof(double));
        return;
    }
    double m[6];
    bm_motion_state(&H->roll, t, m);
    A[0] = m[0]; A[1] = m[1]; A[2] = H->R;
    vA[0] = m[2]; vA[1] = m[3]; vA[2] = 0.0;
    aA[0] = m[4]; aA[1] = m[5]; aA[2] = 0.0;
    Om[0] = 0.0; Om[1] = 0.0; Om[2] = 0.0;
    if (Omd) {
        Omd[0] = 0.0; Omd[1] = 0.0; Omd[2] = 0.0;
    }
}

/* HybridBall.wall_velocity: v_A + Omega x R n */
static void bmh_wall_velocity(const bmh_problem *H, double t, const double *n, double *vW)
{
    double A[3], vA[3], aA[3], Om[3], c[3];
    bmh_chamber(H, t, A, vA, aA, Om, NULL);
    bmh_cross(Om, n, c);
    for (int i = 0; i < 3; i++) vW[i] = vA[i] + H->R * c[i];
}

/* HybridBall._roll_out's N and |F_t| (outputs.evaluate; turning: evaluate_c) of a rolling
 * state (n, omega) */
static void bmh_roll_out(const bmh_problem *H, double t, const double *y, double *N, double *Ft)
{
    if (H->turning) {
        double cs[BMG_NCS], go[BMG_NOUT];
        bmg_state(&H->gen, t, cs);
        bmg_outputs(H->gen.oc, y, cs, go);
        *N = go[13];
        *Ft = go[14];
        return;
    }
    double m[6], o[BM_NOUT];
    bm_motion_state(&H->roll, t, m);
    bm_outputs(&H->roll, y, m[4], m[5], 0.0, 0.0, o);
    *N = o[9];
    *Ft = o[17];
}

/* HybridBall._ff_accel: the friction-free relative tangential acceleration of P of the free
 * state z at n, the chamber at A, v_A, a_A, Omega, Omega' */
static void bmh_ff_accel_at(const bmh_problem *H, const double *vA, const double *aA, const double *Om,
                            const double *Omd, const double *z, const double *n, double *out)
{
    double vrel[3], aC[3], nd[3], wnd[3], c1[3], c2[3], aW[3], a[3];
    for (int i = 0; i < 3; i++) vrel[i] = z[3 + i] - vA[i];
    double N = H->m * (-H->g * n[2] - bmh_dot(n, aA) + bmh_dot(vrel, vrel) / H->d);
    aC[0] = -N * n[0] / H->m;
    aC[1] = -N * n[1] / H->m;
    aC[2] = -H->g - N * n[2] / H->m;
    double vn = bmh_dot(vrel, n);
    for (int i = 0; i < 3; i++) nd[i] = (vrel[i] - vn * n[i]) / H->d;
    bmh_cross(z + 6, nd, wnd);
    bmh_cross(Omd, n, c1);
    bmh_cross(Om, nd, c2);
    for (int i = 0; i < 3; i++) aW[i] = aA[i] + H->R * (c1[i] + c2[i]);
    for (int i = 0; i < 3; i++) a[i] = aC[i] - aW[i] + H->r * wnd[i];
    double an = bmh_dot(a, n);
    for (int i = 0; i < 3; i++) out[i] = a[i] - an * n[i];
}

/* hybrid._smooth: 0 for x <= 0, 1 for x >= 1, 3 x^2 - 2 x^3 between */
static double bmh_smooth(double x)
{
    if (x <= 0.0) return 0.0;
    if (x >= 1.0) return 1.0;
    return x * x * (3.0 - 2.0 * x);
}

/* hybrid.CREEP_COS */
#define BMH_CREEP_COS0 0.9
#define BMH_CREEP_COS1 0.99

/* hybrid._creep_weight: the weight of a0's direction in the sliding friction's direction at the
 * slip ut of speed s < eps */
static double bmh_creep_weight(const double *a, const double *ut, double s, double eps)
{
    double sa2 = bmh_dot(a, a);
    if (sa2 == 0.0) return 0.0;
    if (s == 0.0) return 1.0;
    double c = bmh_dot(a, ut) / (sqrt(sa2) * s);
    return bmh_smooth((eps - s) / (0.5 * eps)) * bmh_smooth((c - BMH_CREEP_COS0) / (BMH_CREEP_COS1 - BMH_CREEP_COS0));
}

/* HybridBall._slide at the chamber state A, v_A, a_A, Omega, Omega': N, the friction force Ft, the
 * slip speed, n, v_W and (p: NULL when not needed) the friction's power -Ft.u_t; the friction's
 * direction u_t/|u_t|, blended below creep_eps towards a0's (the creeping slide), from zero slip
 * seed when a0 = 0 */
static double bmh_slide_forces_at(const bmh_problem *H, const double *A, const double *vA, const double *aA,
                                  const double *Om, const double *Omd, const double *y, const double *seed,
                                  double *Ft, double *s_out, double *n, double *vW, double *p)
{
    double rho[3], vrel[3], wr[3], on[3], u[3], ut[3], e[3], a[3];
    for (int i = 0; i < 3; i++) rho[i] = y[i] - A[i];
    double dist = sqrt(bmh_dot(rho, rho));
    for (int i = 0; i < 3; i++) n[i] = rho[i] / dist;
    for (int i = 0; i < 3; i++) vrel[i] = y[3 + i] - vA[i];
    double N = H->m * (-H->g * n[2] - bmh_dot(n, aA) + bmh_dot(vrel, vrel) / dist);
    bmh_cross(y + 6, n, wr);
    bmh_cross(Om, n, on);
    for (int i = 0; i < 3; i++) u[i] = vrel[i] + H->r * wr[i] - H->R * on[i];
    double un = bmh_dot(u, n);
    for (int i = 0; i < 3; i++) ut[i] = u[i] - un * n[i];
    double s = sqrt(bmh_dot(ut, ut));
    double f = -H->mu_k * N, w = 0.0, pw;
    if (s < H->creep_eps) {
        bmh_ff_accel_at(H, vA, aA, Om, Omd, y, n, a);
        w = bmh_creep_weight(a, ut, s, H->creep_eps);
    }
    if (w == 0.0) {
        if (s > 1e-3 * H->slip_eps) {
            for (int i = 0; i < 3; i++) e[i] = ut[i] / s;
        } else {
            for (int i = 0; i < 3; i++) e[i] = seed[i];
        }
        pw = H->mu_k * N * s;
    } else {
        double sa = sqrt(bmh_dot(a, a));
        if (w == 1.0) {
            for (int i = 0; i < 3; i++) e[i] = a[i] / sa;
        } else {
            double c = (1.0 - w) / s, d = w / sa, v[3];
            for (int i = 0; i < 3; i++) v[i] = c * ut[i] + d * a[i];
            double sv = sqrt(bmh_dot(v, v));
            for (int i = 0; i < 3; i++) e[i] = v[i] / sv;
        }
        pw = -f * bmh_dot(e, ut);
    }
    for (int i = 0; i < 3; i++) Ft[i] = f * e[i];
    for (int i = 0; i < 3; i++) vW[i] = vA[i] + H->R * on[i];
    *s_out = s;
    if (p) *p = pw;
    return N;
}

/* HybridBall._slide: N, the friction force Ft, the slip speed, n, v_W, the friction's power (seed
 * NULL: the run's; p NULL: not needed) */
static double bmh_slide_forces(const bmh_run *run, double t, const double *y, const double *seed, double *Ft,
                               double *s_out, double *n, double *vW, double *p)
{
    double A[3], vA[3], aA[3], Om[3], Omd[3];
    bmh_chamber(run->H, t, A, vA, aA, Om, Omd);
    return bmh_slide_forces_at(run->H, A, vA, aA, Om, Omd, y, seed ? seed : run->seed, Ft, s_out, n, vW, p);
}

/* HybridBall._q_spin: Lq's rate m (v_A x v_C)_z of a translating chamber (0 turning) */
static double bmh_q_spin(const bmh_problem *H, const double *vA, double vCx, double vCy)
{
    if (H->turning) return 0.0;
    return H->m * (vA[0] * vCy - vA[1] * vCx);
}

/* HybridBall.reaction_momentum: K of a free state z at t */
static double bmh_reaction_momentum(const bmh_problem *H, double t, const double *z)
{
    if (H->turning) return H->m * (z[0] * z[4] - z[1] * z[3]) + H->Ib * z[8];
    double A[3], vA[3], aA[3], Om[3];
    bmh_chamber(H, t, A, vA, aA, Om, NULL);
    return H->m * (A[0] * z[4] - A[1] * z[3]);
}

/* the modes' right-hand sides (ctx: the bmh_run) */
static void bmh_rhs_roll_q(const bm_problem *P, const void *ctx, double t, const double *y, double *f)
{
    const bmh_run *run = ctx;
    const bmh_problem *H = run->H;
    double m[6], c1[3], c2[3];
    if (H->turning) { /* turning.derivative, and evaluate_c's P_ball */
        double cs[BMG_NCS], go[BMG_NOUT], kin[9];
        bmg_state(&H->gen, t, cs);
        bmg_outputs(H->gen.oc, y, cs, go);
        bmg_accel(&H->gen, t, kin);
        bmg_derivative(H->gen.c, y, kin, f);
        f[6] = go[24];
        f[7] = 0.0;
        f[8] = 0.0;
        return;
    }
    bm_motion_state(P, t, m);
    bm_derivative(P, y, m[4], m[5], f);
    bmh_cross(f, y + 3, c1);
    bmh_cross(y, f + 3, c2);
    double dl = H->d * H->lam;
    double Fx = H->m * (m[4] + dl * (c1[0] + c2[0]));
    double Fy = H->m * (m[5] + dl * (c1[1] + c2[1]));
    f[6] = Fx * m[2] + Fy * m[3];
    f[7] = 0.0;
    double nw[3];
    bmh_cross(y, y + 3, nw);
    f[8] = bmh_q_spin(H, m + 2, m[2] + H->r * nw[0], m[3] + H->r * nw[1]);
}

/* HybridBall._rhs_roll_l: the rolling model's right-hand side (BallModel.rhs translating,
 * ChamberModel.rhs turning) and Lq's rate */
static void bmh_rhs_roll_l(const bm_problem *P, const void *ctx, double t, const double *y, double *f)
{
    const bmh_run *run = ctx;
    const bmh_problem *H = run->H;
    if (H->turning) {
        bmg_rhs(&H->gen, t, y, f);
        f[6] = 0.0;
        return;
    }
    double m[6], nw[3];
    bm_ball_rhs(P, ctx, t, y, f);
    bm_motion_state(P, t, m);
    bmh_cross(y, y + 3, nw);
    f[6] = bmh_q_spin(H, m + 2, m[2] + H->r * nw[0], m[3] + H->r * nw[1]);
}

static void bmh_rhs_flight(const bm_problem *P, const void *ctx, double t, const double *y, double *f)
{
    const bmh_run *run = ctx;
    const bmh_problem *H = run->H;
    (void)P;
    f[0] = y[3]; f[1] = y[4]; f[2] = y[5];
    f[3] = 0.0; f[4] = 0.0; f[5] = -H->g;
    for (int i = 6; i < BMH_NZ - 1; i++) f[i] = 0.0;
    f[BMH_NZ - 1] = 0.0;
    if (!H->turning) {
        double A[3], vA[3], aA[3], Om[3];
        bmh_chamber(H, t, A, vA, aA, Om, NULL);
        f[BMH_NZ - 1] = bmh_q_spin(H, vA, y[3], y[4]);
    }
}

static void bmh_rhs_slide(const bm_problem *P, const void *ctx, double t, const double *y, double *f)
{
    const bmh_run *run = ctx;
    const bmh_problem *H = run->H;
    double Ft[3], n[3], vW[3], F[3], tq[3], s, p;
    (void)P;
    double N = bmh_slide_forces(run, t, y, NULL, Ft, &s, n, vW, &p);
    for (int i = 0; i < 3; i++) F[i] = Ft[i] - N * n[i];
    bmh_cross(n, Ft, tq);
    double c = H->r / H->Ib;
    f[0] = y[3]; f[1] = y[4]; f[2] = y[5];
    f[3] = F[0] / H->m; f[4] = F[1] / H->m; f[5] = F[2] / H->m - H->g;
    f[6] = c * tq[0]; f[7] = c * tq[1]; f[8] = c * tq[2];
    f[9] = bmh_dot(F, vW);
    f[10] = p;
    f[11] = bmh_q_spin(H, vW, y[3], y[4]); /* translating: v_W = v_A */
}

/* the guards (ctx: the bmh_run): rolling (mu N - |F_t|, N), sliding (|u| - slip_eps, N, hold), flight (gap) */
static void bmh_g_rolling(const void *ctx, double t, const double *y, double *g)
{
    const bmh_run *run = ctx;
    double N, Ft;
    bmh_roll_out(run->H, t, y, &N, &Ft);
    g[0] = run->H->mu * N - Ft;
    g[1] = N;
}

static double bmh_on_sphere(const bmh_problem *H, double t, const double *z_in, double *z, double *n, double *ut);
static void bmh_unslip(const bmh_problem *H, double t, double *z, const double *n, const double *ut, double *N,
                       double *Ft);

/* hybrid.GRIP_SCALE [N s/m]: the grip guard's weight of |u| - slip_eps */
#define BMH_GRIP_SCALE 0x1p-30

/* HybridBall._g_sliding: |u| - slip_eps, N and the grip guard (at and below slip_eps
 * max(|F_t| - mu N, GRIP_SCALE (|u| - slip_eps)) with the rolling model's |F_t| and N where the
 * stick map would put the ball; above, GRIP_SCALE (|u| - slip_eps)) */
static void bmh_g_sliding(const void *ctx, double t, const double *y, double *g)
{
    const bmh_run *run = ctx;
    const bmh_problem *H = run->H;
    double Ft[3], n[3], vW[3], s;
    double N = bmh_slide_forces(run, t, y, NULL, Ft, &s, n, vW, NULL);
    g[0] = s - H->slip_eps;
    g[1] = N;
    if (g[0] > 0.0) {
        g[2] = BMH_GRIP_SCALE * g[0];
        return;
    }
    double z[BMH_NZ], nz[3], ut[3], Nr, Ftr;
    bmh_on_sphere(H, t, y, z, nz, ut);
    bmh_unslip(H, t, z, nz, ut, &Nr, &Ftr);
    g[2] = bm_pymax(Ftr - H->mu * Nr, BMH_GRIP_SCALE * g[0]);
}

static double bmh_gap(const bmh_problem *H, double t, const double *y)
{
    double A[3], vA[3], aA[3], Om[3];
    bmh_chamber(H, t, A, vA, aA, Om, NULL);
    return H->d - sqrt(bm_sq(y[0] - A[0]) + bm_sq(y[1] - A[1]) + bm_sq(y[2] - A[2]));
}

static void bmh_g_flight(const void *ctx, double t, const double *y, double *g)
{
    const bmh_run *run = ctx;
    g[0] = bmh_gap(run->H, t, y);
}

/* HybridBall._normal_motion: v_n (> 0 towards the wall) and the free flight's a_n */
static void bmh_normal_motion(const bmh_problem *H, double t, const double *y, double *vn, double *an)
{
    double A[3], vA[3], aA[3], Om[3], rho[3], n[3];
    bmh_chamber(H, t, A, vA, aA, Om, NULL);
    for (int i = 0; i < 3; i++) rho[i] = y[i] - A[i];
    double dist = sqrt(bmh_dot(rho, rho));
    for (int i = 0; i < 3; i++) n[i] = rho[i] / dist;
    *vn = (y[3] - vA[0]) * n[0] + (y[4] - vA[1]) * n[1] + (y[5] - vA[2]) * n[2];
    *an = -H->g * n[2] - bmh_dot(aA, n);
}

/* HybridBall.free_state: (C, v_C, omega, W, E_friction, Lq) of any mode's state */
static void bmh_free_state(const bmh_run *run, int mode, double t, const double *y, double *z)
{
    const bmh_problem *H = run->H;
    if (mode != BMH_ROLLING) {
        memcpy(z, y, BMH_NZ * sizeof(double));
        return;
    }
    double A[3], vA[3], aA[3], Om[3], nw[3], vW[3];
    bmh_chamber(H, t, A, vA, aA, Om, NULL);
    bmh_cross(y, y + 3, nw);
    bmh_wall_velocity(H, t, y, vW);
    for (int i = 0; i < 3; i++) {
        z[i] = A[i] + H->d * y[i];
        z[3 + i] = vW[i] + H->r * nw[i];
        z[6 + i] = y[3 + i];
    }
    z[9] = H->energy ? y[6] : run->Q[0];
    z[10] = H->energy ? y[7] : run->Q[1];
    z[11] = y[H->roll.ny - 1];
}

/* HybridBall._rolling_state: the rolling state of n, omega and the quadratures; its size */
static int bmh_rolling_state(bmh_run *run, const double *n, const double *w, double W, double Ef, double Lq,
                             double *y)
{
    memcpy(y, n, 3 * sizeof(double));
    memcpy(y + 3, w, 3 * sizeof(double));
    if (run->H->energy) {
        y[6] = W;
        y[7] = Ef;
        y[8] = Lq;
        return 9;
    }
    run->Q[0] = 0.0; /* W is not followed while rolling (HybridBall._rolling_state) */
    run->Q[1] = Ef;
    run->w_lost = 1;
    y[6] = Lq;
    return 7;
}

/* HybridBall._impulse: J (on the ball, at P) applied to z in place; the kinetic energy lost in
 * the frame of the wall's material point at P, J.v_W added to W */
static double bmh_impulse(const bmh_problem *H, double t, double *z, const double *J, const double *n)
{
    double vW[3], tq[3], v[3];
    bmh_wall_velocity(H, t, n, vW);
    for (int i = 0; i < 3; i++) v[i] = z[3 + i] - vW[i];
    double before = 0.5 * H->m * bmh_dot(v, v) + 0.5 * H->Ib * (bm_sq(z[6]) + bm_sq(z[7]) + bm_sq(z[8]));
    bmh_cross(n, J, tq);
    for (int i = 0; i < 3; i++) {
        z[3 + i] += J[i] / H->m;
        z[6 + i] += H->r * tq[i] / H->Ib;
    }
    z[9] += bmh_dot(J, vW);
    for (int i = 0; i < 3; i++) v[i] = z[3 + i] - vW[i];
    return before - (0.5 * H->m * bmh_dot(v, v) + 0.5 * H->Ib * (bm_sq(z[6]) + bm_sq(z[7]) + bm_sq(z[8])));
}

/* HybridBall._slip with the wall's velocity vW at P: the tangential slip of a free state at C + r n */
static void bmh_slip_at(const bmh_problem *H, const double *vW, const double *z, const double *n, double *ut)
{
    double wr[3], u[3];
    bmh_cross(z + 6, n, wr);
    for (int i = 0; i < 3; i++) u[i] = z[3 + i] - vW[i] + H->r * wr[i];
    double un = bmh_dot(u, n);
    for (int i = 0; i < 3; i++) ut[i] = u[i] - un * n[i];
}

/* HybridBall._slip: the tangential slip of a free state at the wall point C + r n */
static void bmh_slip(const bmh_problem *H, double t, const double *z, const double *n, double *ut)
{
    double vW[3];
    bmh_wall_velocity(H, t, n, vW);
    bmh_slip_at(H, vW, z, n, ut);
}

/* HybridBall._friction_free_slip_accel */
static void bmh_ff_slip_accel(const bmh_problem *H, double t, const double *z, const double *n, double *out)
{
    double A[3], vA[3], aA[3], Om[3], Omd[3];
    bmh_chamber(H, t, A, vA, aA, Om, Omd);
    bmh_ff_accel_at(H, vA, aA, Om, Omd, z, n, out);
}

/* details of an event (an event record's fields 8..17; NAN: absent) */
enum { BMH_D_VN = 8, BMH_D_SLIP, BMH_D_STICK, BMH_D_ELOSS, BMH_D_REST, BMH_D_REMOVED, BMH_D_SEED,
       BMH_D_GRAZING = BMH_D_SEED + 3 };

/* HybridBall._start_sliding */
static int bmh_start_sliding(bmh_run *run, double t, const double *z, const double *n, double *rec)
{
    double a[3];
    bmh_ff_slip_accel(run->H, t, z, n, a);
    double s = sqrt(bmh_dot(a, a));
    for (int i = 0; i < 3; i++) run->seed[i] = s > 0.0 ? a[i] / s : 0.0;
    if (isnan(run->t_first_slip)) run->t_first_slip = t;
    memcpy(rec + BMH_D_SEED, run->seed, sizeof run->seed);
    return BMH_SLIDING;
}

/* HybridBall._remove_slip: the slip ut of the free state z on the wall removed (in place) by the
 * tangential impulse -m ut / k_t at P, its energy booked as friction loss */
static void bmh_remove_slip(const bmh_problem *H, double t, double *z, const double *n, const double *ut)
{
    double J[3];
    for (int i = 0; i < 3; i++) J[i] = -H->m * ut[i] / H->kt;
    double loss = bmh_impulse(H, t, z, J, n);
    z[10] += loss;
}

/* HybridBall._remove_normal: the normal velocity of z relative to the wall (the chamber's centre
 * at vA) removed (in place) by a normal impulse at P; returns the energy it takes */
static double bmh_remove_normal(const bmh_problem *H, double t, double *z, const double *n, const double *vA)
{
    double vn = (z[3] - vA[0]) * n[0] + (z[4] - vA[1]) * n[1] + (z[5] - vA[2]) * n[2], J[3];
    for (int i = 0; i < 3; i++) J[i] = -H->m * vn * n[i];
    return bmh_impulse(H, t, z, J, n);
}

/* HybridBall._on_sphere: z (a copy of the free state z_in) with C put on |C - A| = d, n there
 * and the tangential slip ut; returns its speed */
static double bmh_on_sphere(const bmh_problem *H, double t, const double *z_in, double *z, double *n, double *ut)
{
    double A[3], vA[3], aA[3], Om[3], rho[3];
    bmh_chamber(H, t, A, vA, aA, Om, NULL);
    memcpy(z, z_in, BMH_NZ * sizeof(double));
    for (int i = 0; i < 3; i++) rho[i] = z[i] - A[i];
    double q = sqrt(bmh_dot(rho, rho));
    for (int i = 0; i < 3; i++) n[i] = rho[i] / q;
    for (int i = 0; i < 3; i++) z[i] = A[i] + H->d * n[i];
    bmh_slip(H, t, z, n, ut);
    return sqrt(bmh_dot(ut, ut));
}

/* HybridBall._unslip: the stick map, the slip ut of z removed in place by the tangential impulse
 * -m ut / k_t (its energy booked as friction); the rolling model's N and |F_t| there */
static void bmh_unslip(const bmh_problem *H, double t, double *z, const double *n, const double *ut, double *N,
                       double *Ft)
{
    double nw[6];
    bmh_remove_slip(H, t, z, n, ut);
    memcpy(nw, n, 3 * sizeof(double));
    memcpy(nw + 3, z + 6, 3 * sizeof(double));
    bmh_roll_out(H, t, nw, N, Ft);
}

/* HybridBall.on_wall: the mode and state (y, *ny) of a ball on the wall with no normal
 * relative velocity (free state z), its slip removed if below slip_eps (or stuck: at a stick
 * event, whatever its speed), then the stick test */
static int bmh_on_wall(bmh_run *run, double t, const double *z_in, double *y, int *ny, double *rec, int stuck)
{
    const bmh_problem *H = run->H;
    double z[BMH_NZ], n[3], ut[3];
    double s = bmh_on_sphere(H, t, z_in, z, n, ut);
    memcpy(y, z, sizeof z);
    *ny = BMH_NZ;
    if (s <= H->slip_eps || stuck) {
        double N, Ft;
        bmh_unslip(H, t, z, n, ut, &N, &Ft);
        rec[BMH_D_REMOVED] = s;
        memcpy(y, z, sizeof z);
        if (N <= 0.0) return BMH_FLIGHT;
        if (Ft <= H->mu * N) {
            *ny = bmh_rolling_state(run, n, z + 6, z[9], z[10], z[11], y);
            return BMH_ROLLING;
        }
        return bmh_start_sliding(run, t, z, n, rec);
    }
    double zero[3] = {0.0, 0.0, 0.0}, Ftv[3], nn[3], vW[3], ss;
    double N = bmh_slide_forces(run, t, z, zero, Ftv, &ss, nn, vW, NULL);
    if (N <= 0.0) return BMH_FLIGHT;
    if (isnan(run->t_first_slip)) run->t_first_slip = t;
    return BMH_SLIDING;
}

/* HybridBall._onto_wall: C put on |C - A| = d and the normal relative velocity removed */
static void bmh_onto_wall(const bmh_problem *H, double t, double *z)
{
    double A[3], vA[3], aA[3], Om[3], rho[3], n[3], v[3];
    bmh_chamber(H, t, A, vA, aA, Om, NULL);
    for (int i = 0; i < 3; i++) rho[i] = z[i] - A[i];
    double q = sqrt(bmh_dot(rho, rho));
    for (int i = 0; i < 3; i++) n[i] = rho[i] / q;
    for (int i = 0; i < 3; i++) z[i] = A[i] + H->d * n[i];
    for (int i = 0; i < 3; i++) v[i] = z[3 + i] - vA[i];
    double vn = bmh_dot(v, n);
    for (int i = 0; i < 3; i++) z[3 + i] -= vn * n[i];
}

/* HybridBall._impact */
static int bmh_impact(bmh_run *run, double t, const double *z_in, double *y, int *ny, double *rec)
{
    const bmh_problem *H = run->H;
    double A[3], vA[3], aA[3], Om[3], z[BMH_NZ], rho[3], n[3], ut[3], Jt[3], J[3];
    bmh_chamber(H, t, A, vA, aA, Om, NULL);
    memcpy(z, z_in, sizeof z);
    for (int i = 0; i < 3; i++) rho[i] = z[i] - A[i];
    double q = sqrt(bmh_dot(rho, rho));
    for (int i = 0; i < 3; i++) n[i] = rho[i] / q;
    for (int i = 0; i < 3; i++) z[i] = A[i] + H->d * n[i];
    double vn = (z[3] - vA[0]) * n[0] + (z[4] - vA[1]) * n[1] + (z[5] - vA[2]) * n[2];
    rec[BMH_D_VN] = vn;
    memcpy(y, z, sizeof z);
    *ny = BMH_NZ;
    if (vn <= 0.0) { /* touching without approaching: no impulse */
        rec[BMH_D_GRAZING] = 1.0;
        return BMH_FLIGHT;
    }
    double Jn = (1.0 + H->e_n) * H->m * vn;
    bmh_slip(H, t, z, n, ut);
    double s = sqrt(bmh_dot(ut, ut));
    int stick = s / H->kt <= H->mu * (1.0 + H->e_n) * vn;
    if (stick) {
        for (int i = 0; i < 3; i++) Jt[i] = -H->m * ut[i] / H->kt;
    } else {
        double c = -H->mu_k * Jn / s;
        for (int i = 0; i < 3; i++) Jt[i] = c * ut[i];
    }
    for (int i = 0; i < 3; i++) J[i] = Jt[i] - Jn * n[i];
    double loss = bmh_impulse(H, t, z, J, n);
    run->n_impacts += 1.0;
    run->v_impact_max = bm_pymax(run->v_impact_max, vn);
    rec[BMH_D_SLIP] = s;
    rec[BMH_D_STICK] = stick;
    rec[BMH_D_ELOSS] = loss;
    double vn_, an;
    bmh_normal_motion(H, t, z, &vn_, &an);
    double hop = an > 0.0 ? bm_sq(H->e_n * vn) / (2.0 * an) : INFINITY;
    memcpy(y, z, sizeof z);
    if (H->e_n * vn < H->v_rest || hop < H->gap_res) {
        loss += bmh_remove_normal(H, t, z, n, vA);
        run->E_impact += loss;
        rec[BMH_D_ELOSS] = loss;
        rec[BMH_D_REST] = 1.0;
        return bmh_on_wall(run, t, z, y, ny, rec, 0);
    }
    run->E_impact += loss;
    run->rebound = 1;
    return BMH_FLIGHT;
}

/* HybridBall.hold: at a Zeno stop at t (window: the burst's span), the ball put on the wall and held
 * there, rolling only from now on: C onto the sphere, its normal velocity relative to the wall removed
 * (impact loss), then its slip (friction loss); the hold booked. The rolling state in y; its size. */
static int bmh_hold(bmh_run *run, int mode, double t, const double *y_in, double *y, double window)
{
    const bmh_problem *H = run->H;
    double A[3], vA[3], aA[3], Om[3], zf[BMH_NZ], z[BMH_NZ], n[3], ut[3];
    bmh_chamber(H, t, A, vA, aA, Om, NULL);
    bmh_free_state(run, mode, t, y_in, zf);
    bmh_on_sphere(H, t, zf, z, n, ut);
    double loss = bmh_remove_normal(H, t, z, n, vA);
    run->E_impact += loss;
    bmh_slip(H, t, z, n, ut);
    bmh_remove_slip(H, t, z, n, ut);
    run->t_held = t;
    run->held_window = window;
    run->rebound = 0;
    return bmh_rolling_state(run, n, z + 6, z[9], z[10], z[11], y);
}

/* HybridBall.jump: the new mode and state (y, *ny) at an event of `kind`; rec: the event record */
static int bmh_jump(bmh_run *run, int mode, int kind, double t, const double *y_in, double *y, int *ny,
                    double *rec)
{
    const bmh_problem *H = run->H;
    double z[BMH_NZ], A[3], vA[3], aA[3], Om[3], n[3], rho[3];
    int new_mode;
    run->rebound = 0;
    bmh_free_state(run, mode, t, y_in, z);
    bmh_chamber(H, t, A, vA, aA, Om, NULL);
    if (kind == BMH_IMPACT) {
        new_mode = bmh_impact(run, t, z, y, ny, rec);
    } else if (kind == BMH_LEAVE) {
        memcpy(y, z, sizeof z);
        bmh_onto_wall(H, t, y);
        *ny = BMH_NZ;
        new_mode = BMH_FLIGHT;
    } else if (kind == BMH_SLIP) {
        double zero[3] = {0.0, 0.0, 0.0}, Ftv[3], nn[3], vW[3], ss;
        memcpy(y, z, sizeof z);
        *ny = BMH_NZ;
        if (bmh_slide_forces(run, t, z, zero, Ftv, &ss, nn, vW, NULL) <= 0.0) {
            /* rolling's two guards met at N = 0: the wall no longer presses (HybridBall.jump) */
            bmh_onto_wall(H, t, y);
            new_mode = BMH_FLIGHT;
        } else {
            for (int i = 0; i < 3; i++) n[i] = (z[i] - A[i]) / H->d;
            new_mode = bmh_start_sliding(run, t, z, n, rec);
        }
    } else {
        new_mode = bmh_on_wall(run, t, z, y, ny, rec, 1);
    }
    if (new_mode == BMH_FLIGHT && isnan(run->t_first_flight)) run->t_first_flight = t;
    for (int i = 0; i < 3; i++) rho[i] = z[i] - A[i];
    double q = sqrt(bmh_dot(rho, rho));
    for (int i = 0; i < 3; i++) rec[5 + i] = rho[i] / q;
    return new_mode;
}

/* HybridBall.sample: one row of COLUMNS */
static void bmh_sample(const bmh_run *run, int mode, double t, const double *y, double *row)
{
    const bmh_problem *H = run->H;
    double z[BMH_NZ], A[3], vA[3], aA[3], Om[3], rho[3], n[3], N, Ft, slip;
    bmh_free_state(run, mode, t, y, z);
    bmh_chamber(H, t, A, vA, aA, Om, NULL);
    for (int i = 0; i < 3; i++) rho[i] = z[i] - A[i];
    double dist = sqrt(bmh_dot(rho, rho));
    for (int i = 0; i < 3; i++) n[i] = rho[i] / dist;
    if (mode == BMH_ROLLING) {
        memcpy(n, y, sizeof n);
        bmh_roll_out(H, t, y, &N, &Ft);
        slip = 0.0;
    } else if (mode == BMH_SLIDING) {
        double Ftv[3], nn[3], vW[3];
        N = bmh_slide_forces(run, t, z, NULL, Ftv, &slip, nn, vW, NULL);
        Ft = sqrt(bmh_dot(Ftv, Ftv));
    } else {
        double ut[3];
        N = 0.0;
        Ft = 0.0;
        bmh_slip(H, t, z, n, ut);
        slip = sqrt(bmh_dot(ut, ut));
    }
    double E = 0.5 * H->m * bmh_dot(z + 3, z + 3) + 0.5 * H->Ib * bmh_dot(z + 6, z + 6) + H->m * H->g * z[2];
    row[0] = mode;
    memcpy(row + 1, n, sizeof n);
    row[4] = z[0] - A[0]; row[5] = z[1] - A[1]; row[6] = z[2];
    if (H->turning) { /* into the chamber's axes: Q^T (C - A) + (0, 0, R) */
        double cs[BMG_NCS], r[3] = {row[4], row[5], z[2] - A[2]};
        const double *Q = cs + 15;
        bmg_state(&H->gen, t, cs);
        for (int i = 0; i < 3; i++) row[4 + i] = Q[i] * r[0] + Q[3 + i] * r[1] + Q[6 + i] * r[2];
        row[6] = row[6] + H->R;
    }
    memcpy(row + 7, z + 3, 6 * sizeof(double));
    row[13] = N; row[14] = Ft; row[15] = slip; row[16] = H->d - dist; row[17] = E;
    row[18] = run->w_lost ? NAN : z[9];
    row[19] = z[10];
    row[20] = run->E_impact; row[21] = run->n_impacts; row[22] = run->v_impact_max;
    row[23] = run->t_first_slip; row[24] = run->t_first_flight;
    row[25] = z[11] - bmh_reaction_momentum(H, t, z);
}

/* the hybrid ball as a system of bm_drive (events.integrate's HybridBall) */
typedef struct {
    bm_system sys;
    bmh_run run;
    bm_tab Tr, Tf;
    double *rows, *events, *y_out, h_out;
    long long cap, ne;
    int ring; /* events: a ring of the last cap records (cap >= burst: what the Zeno guard reads) */
    int mode_out;
} bmh_sys;

/* event record k of the run */
static double *bmh_event(const bmh_sys *x, long long k)
{
    return x->events + BMH_NEV * (x->ring ? k % x->cap : k);
}

/* the mode's integrator problem, tableau, right-hand side and guards (HybridBall.integrator,
 * rhs, guards, armed) */
static void bmh_setup(const bm_system *S, int mode, double t, const double *y, const bm_problem **P,
                      const bm_tab **T, bm_rhs_fn *rhs, const void **ctx, bm_events *ev)
{
    const bmh_sys *x = (const bmh_sys *)S;
    const bmh_problem *H = x->run.H;
    (void)t; (void)y;
    *ctx = &x->run;
    ev->gctx = &x->run;
    ev->scan = H->scan;
    ev->xtol = H->xtol;
    if (mode == BMH_ROLLING) {
        *P = &H->roll; *T = &x->Tr;
        *rhs = H->energy ? bmh_rhs_roll_q : bmh_rhs_roll_l;
        ev->ng = isnan(x->run.t_held) ? 2 : 0; /* held on the wall (bmh_hold): the rolling model only */
        ev->G = bmh_g_rolling;
    } else {
        *P = &H->free; *T = &x->Tf;
        *rhs = mode == BMH_SLIDING ? bmh_rhs_slide : bmh_rhs_flight;
        ev->ng = mode == BMH_SLIDING ? 3 : 1;
        ev->G = mode == BMH_SLIDING ? bmh_g_sliding : bmh_g_flight;
        ev->levels[0] = mode == BMH_SLIDING ? 0.0 : H->gap_res;
        ev->armed[0] = mode == BMH_FLIGHT && x->run.rebound; /* an opening gap after a rebound */
    }
}

/* HybridBall.jump at the event, its record, HybridBall.first_step, and the Zeno guard */
static int bmh_sys_jump(bm_system *S, int *mode, double *t, double *y, double *h, const bm_events *ev,
                        int *status)
{
    static const int kinds[3][3] = {{BMH_IMPACT, -1, -1}, {BMH_SLIP, BMH_LEAVE, -1},
                                    {BMH_STICK, BMH_LEAVE, BMH_STICK}}; /* HybridBall.guards */
    bmh_sys *x = (bmh_sys *)S;
    const bmh_problem *H = x->run.H;
    int kind = kinds[*mode][ev->j], ny;
    if (!x->ring && x->ne >= x->cap) {
        *status = 3;
        return 0;
    }
    double *rec = bmh_event(x, x->ne);
    for (int q = 0; q < BMH_NEV; q++) rec[q] = NAN;
    int new_mode = bmh_jump(&x->run, *mode, kind, ev->t, ev->y, y, &ny, rec);
    rec[0] = ev->t; rec[1] = kind; rec[2] = *mode; rec[3] = new_mode; rec[4] = ev->width;
    x->ne++;
    *mode = new_mode;
    *t = ev->t;
    *h = ev->h_used;
    if (new_mode == BMH_FLIGHT && x->run.rebound) { /* HybridBall.first_step */
        double vn, an;
        bmh_normal_motion(H, *t, y, &vn, &an);
        if (vn < 0.0 && an > 0.0) *h = bm_pymin(*h, bm_pymax(0.5 * -vn / an, 1e-12));
    }
    if (x->ne >= H->burst && *t - bmh_event(x, x->ne - H->burst)[0] < H->burst / H->max_rate) {
        if (!H->zeno_hold) {
            *status = 2;
            return 0;
        }
        double yh[BMH_NZ];
        memcpy(yh, y, sizeof yh);
        bmh_hold(&x->run, new_mode, *t, yh, y, *t - bmh_event(x, x->ne - H->burst)[0]);
        *mode = BMH_ROLLING;
    }
    return 1;
}

static int bmh_record(bm_system *S, long long i, int mode, double t, const double *y, double h)
{
    bmh_sys *x = (bmh_sys *)S;
    bmh_sample(&x->run, mode, t, y, x->rows + BMH_NCOL * i);
    x->mode_out = mode;
    x->h_out = h;
    memcpy(x->y_out, y, (size_t)(mode == BMH_ROLLING ? x->run.H->roll.ny : BMH_NZ) * sizeof(double));
    return 0;
}

/* events.integrate for the hybrid ball over times[0..n-1] from *mode and y (size: *mode's)
 * at times[0] with step *h, book the bookkeeping (BMH_NBOOK values: E_impact, n_impacts,
 * v_impact_max, t_first_slip, t_first_flight, Q[2], seed[3], rebound, W_lost) in and out;
 * point 0 sampled only if record_start. rows: BMH_NCOL per point; events: BMH_NEV per event,
 * at most cap (ring: the last cap, the run going on; *n_events the events before the run in,
 * all of them out). first_step: an adaptive run whose *h is not a positive number starts
 * with the initial step of its mode (Integrator.initial_step over the first interval). Returns
 * the index of the last point reached; *status as bmh_simulate's. */
static long long bmh_run_grid(const bmh_problem *H, const double *times, long long n, int record_start,
                              int first_step, int *mode_io, double *y, double *h, double *book, double *rows,
                              double *events, long long cap, int ring, long long *n_events, int *status,
                              bm_stats *total)
{
    bmh_sys x;
    double yy[BM_NYMAX];
    memset(&x, 0, sizeof x);
    x.sys.setup = bmh_setup;
    x.sys.jump = bmh_sys_jump;
    x.sys.record = bmh_record;
    bmh_run run = {H, book[0], book[1], book[2], book[3], book[4], {book[5], book[6]},
                   {book[7], book[8], book[9]}, book[10] != 0.0, book[11] != 0.0, book[BMH_BOOK_T_HELD],
                   book[BMH_BOOK_HELD_WINDOW]};
    x.run = run;
    bm_tab_make(&H->roll, &x.Tr);
    bm_tab_make(&H->free, &x.Tf);
    x.rows = rows;
    x.events = events;
    x.cap = cap;
    x.ring = ring;
    x.ne = ring ? *n_events : 0;
    x.y_out = y;
    x.mode_out = *mode_io;
    x.h_out = *h;
    *status = 0;
    long long last = -1;
    if (n > 0) {
        int mode = *mode_io;
        memcpy(yy, y, (size_t)(mode == BMH_ROLLING ? H->roll.ny : BMH_NZ) * sizeof(double));
        if (first_step && n > 1) { /* Integrator.steps' start without a step to try */
            const bm_problem *P;
            const bm_tab *T;
            bm_rhs_fn rhs;
            const void *ctx;
            bm_events ev;
            double f0[BM_NYMAX];
            memset(&ev, 0, sizeof ev);
            bmh_setup(&x.sys, mode, times[0], yy, &P, &T, &rhs, &ctx, &ev);
            if (P->adaptive && !(*h > 0.0 && isfinite(*h))) {
                rhs(P, ctx, times[0], yy, f0);
                if (bm_all_finite(f0, P->ny)) {
                    *h = bm_initial_step_np(P, rhs, ctx, times[0], yy, f0, times[1] - times[0]);
                    total->nfev += 2;
                }
            }
        }
        last = bm_drive(&x.sys, times, n, 0, record_start, &mode, yy, h, total, status);
    }
    *mode_io = x.mode_out;
    *h = x.h_out;
    *n_events = x.ne;
    book[0] = x.run.E_impact; book[1] = x.run.n_impacts; book[2] = x.run.v_impact_max;
    book[3] = x.run.t_first_slip; book[4] = x.run.t_first_flight;
    book[5] = x.run.Q[0]; book[6] = x.run.Q[1];
    memcpy(book + 7, x.run.seed, sizeof x.run.seed);
    book[10] = x.run.rebound;
    book[11] = x.run.w_lost;
    book[BMH_BOOK_T_HELD] = x.run.t_held;
    book[BMH_BOOK_HELD_WINDOW] = x.run.held_window;
    return last;
}

/* events.integrate for the hybrid ball over times[0..n-1] (times[0] the start time, sampled)
 * from *mode and y (size: *mode's) with step *h (the first one from Python's initial step).
 * book: the bookkeeping (BMH_NBOOK values: E_impact, n_impacts, v_impact_max, t_first_slip,
 * t_first_flight, Q[2], seed[3], rebound, W_lost) in and out. rows: BMH_NCOL per point reached;
 * events: BMH_NEV per event, at most cap. Returns the number of points reached (rows); *mode,
 * y and *h the state and step at the last of them, and sets *status: 0 completed; 1 a step failed (Python
 * redoes the run and reports it); 2 a Zeno sequence (the last event is the one that made
 * it); 3 more than cap events (Python redoes the run with more room). *n_events: the events
 * recorded; *total: the work of the completed intervals. */
BM_EXPORT long long bmh_simulate(const bmh_problem *H, const double *times, long long n, int *mode_io, double *y,
                                 double *h, double *book, double *rows, double *events, long long cap,
                                 long long *n_events, int *status, bm_stats *total)
{
    return bmh_run_grid(H, times, n, 1, 0, mode_io, y, h, book, rows, events, cap, 0, n_events, status, total) + 1;
}

/* One interval t -> t_end of the hybrid ball (events.integrate over the grid (t, t_end)), the
 * communication step of the native BallInShell FMU (contact = 2): from *mode, y (its mode's
 * size), the step *h to try (not a positive number: the mode's initial step, as
 * Integrator.steps starts) and the bookkeeping book (bmh_simulate's), all updated to t_end on
 * success; row: HybridBall.sample at t_end (BMH_NCOL). events: a ring of the last cap >= burst
 * event records, *n_events the events so far (in and out), so that the Zeno guard sees the
 * events of earlier intervals. Returns 0 (done), 1 (a step failed), 2 (a Zeno sequence): then
 * *mode, y and *h are as they were (book and events are not: the caller keeps its own copy). */
BM_EXPORT int bmh_interval(const bmh_problem *H, double t, double t_end, int *mode, double *y, double *h,
                           double *book, double *events, long long cap, long long *n_events, double *row,
                           bm_stats *total)
{
    double times[2] = {t, t_end}, rows[2 * BMH_NCOL];
    int status;
    bmh_run_grid(H, times, 2, 0, 1, mode, y, h, book, rows, events, cap, 1, n_events, &status, total);
    if (!status) memcpy(row, rows + BMH_NCOL, sizeof rows / 2);
    return status;
}

BM_EXPORT size_t bmh_problem_size(void) { return sizeof(bmh_problem); }

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
