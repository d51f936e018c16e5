/* drive_models/inductionmotor.c: the native InductionMotor FMU's model (the FMI plumbing
 * is fmu_src/native/fmi2.c; the variables come from ballmill/fmi/interface.py through the
 * generated InductionMotor_interface.h, the DOP853 tableau from integrators.py through
 * bm_tableaus.h, the integrator from the kernel ballmill/physics/_kernel.c).
 *
 * What drive_models/inductionmotor_fmu.py does with ballmill.physics.drives.induction, in the same
 * operation order: a three-phase induction motor from its datasheet (Kloss's torque, or
 * a dq model of four fluxes whose resistances and inductances are fitted to the same
 * datasheet), a starter (direct on line, voltage ramp, V/f ramp), an ideal gear of ratio
 * i and the crank shaft with the platform,
 *     J_total psi'' = i T_motor + M_reaction,  J_total = J_crank + m_platform l^2 + i^2 J_rotor,
 * integrated by DOP853 with the step carried across communication points; M_reaction
 * over a step is held or extrapolated linearly from the last two communication points.
 *
 * The dq fit solves the three datasheet conditions (rated torque, breakdown torque,
 * power factor) by Newton's method where the Python path uses scipy's least_squares:
 * both converge to the same parameters within ~1e-15, so the dq flavours agree to
 * round-off rather than bit for bit; the Kloss model agrees bit for bit.
 */
#include <complex.h>
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "fmu_model.h"
#include "InductionMotor_interface.h"
#include "bm_tableaus.h"
#include "crank_kinematics.h"
#include "_kernel.c"

#define NZ_MAX 7 /* psi, psi', four fluxes (dq), W_motor */
#define MAX_INTERNAL_STEPS 20000 /* work bound: internal DOP853 steps of one doStep */
#define RPM (2.0 * M_PI / 60.0)

typedef struct {
    /* configuration */
    bm_problem P;
    bm_tab T;
    int dq, start, linear_load, nz;
    double p, fn, ramp_time, u_start, f_start;
    double w_sync, Tb, sb, v_peak;   /* motor */
    double Rs, Rr, Lsig, Lm;         /* dq model */
    double i, J, l;                  /* gear, shaft, crank */
    /* dynamic state */
    double z[NZ_MAX];
    double h; /* next DOP853 step; NAN: choose one */
    int n_samples;
    double st[4], sm[4]; /* the last communication points' times and M_reaction, oldest first */
} induction_motor;

typedef struct {
    const induction_motor *m;
    double tk, mk, slope;
} load_ctx;

/* Python's x ** 2 (libm's pow, not the compiler's x * x) */
static double py_square(double x)
{
    volatile double two = 2.0;
    return pow(x, two);
}

/* ===================================================================== the motor */
/* InductionMotor.supply: (U/Un, f/fn) at t */
static void supply(const induction_motor *m, double t, double *u, double *f)
{
    if (t < 0.0) {
        *u = 0.0; *f = 1.0;
        return;
    }
    double x = bm_pymin(t / m->ramp_time, 1.0);
    if (m->start == 1) {
        *u = 1.0; *f = 1.0;
    } else if (m->start == 2) {
        *u = m->u_start + (1.0 - m->u_start) * x; *f = 1.0;
    } else {
        *f = m->f_start + (1.0 - m->f_start) * x; *u = *f;
    }
}

/* InductionMotor.torque: Kloss (V/f below the rated frequency) */
static double kloss_torque(const induction_motor *m, double w_motor, double t)
{
    double u, f;
    supply(m, t, &u, &f);
    double flux = f > 0.0 ? u / f : 1.0;
    double dw = f * m->w_sync - w_motor;
    double dwb = m->sb * m->w_sync;
    return flux * flux * 2.0 * m->Tb * dw * dwb / (dw * dw + dwb * dwb);
}

/* InductionMotor.dq_currents: (isd, isq, ird, irq) from the fluxes */
static void dq_currents(const induction_motor *m, const double *x, double c[4])
{
    double Ls = m->Lsig + m->Lm, Lr = m->Lsig + m->Lm, Lm = m->Lm;
    double det = Ls * Lr - Lm * Lm;
    c[0] = (Lr * x[0] - Lm * x[2]) / det;
    c[1] = (Lr * x[1] - Lm * x[3]) / det;
    c[2] = (Ls * x[2] - Lm * x[0]) / det;
    c[3] = (Ls * x[3] - Lm * x[1]) / det;
}

static double dq_torque(const induction_motor *m, const double *x)
{
    double c[4];
    dq_currents(m, x, c);
    return 1.5 * m->p * (x[0] * c[1] - x[1] * c[0]);
}

/* the drive's right-hand side (FMU._rhs): z = (psi, psi', [fluxes], W_motor) */
static void drive_rhs(const bm_problem *P, const void *ctx, double t, const double *z, double *dz)
{
    const load_ctx *L = ctx;
    const induction_motor *m = L->m;
    double load = L->mk + L->slope * (t - L->tk);
    double w_m = m->i * z[1];
    (void)P;
    if (!m->dq) {
        double T = kloss_torque(m, w_m, t);
        dz[0] = z[1];
        dz[1] = (m->i * T + load) / m->J;
        dz[2] = T * w_m;
        return;
    }
    const double *x = z + 2;
    double T = dq_torque(m, x), c[4], u, f;
    dz[0] = z[1];
    dz[1] = (m->i * T + load) / m->J;
    supply(m, t, &u, &f);
    double w = 2.0 * M_PI * m->fn * f;
    double wr = w - m->p * w_m;
    dq_currents(m, x, c);
    dz[2] = u * m->v_peak - m->Rs * c[0] + w * x[1];
    dz[3] = -m->Rs * c[1] - w * x[0];
    dz[4] = -m->Rr * c[2] + wr * x[3];
    dz[5] = -m->Rr * c[3] - wr * x[2];
    dz[6] = T * w_m;
}

/* the load M_reaction(t) over the coming step from the samples (FMU._load): the newest
 * sample (tk, mk) and, when has_prev, the one the slope comes from */
static load_ctx make_load(const induction_motor *m, int has_prev, double tp, double mp, double tk, double mk)
{
    load_ctx L = {m, tk, mk, 0.0};
    if (m->linear_load && has_prev && tk > tp) L.slope = (mk - mp) / (tk - tp);
    return L;
}

static void publish(const induction_motor *m, const load_ctx *L, double t, double *v)
{
    const double *z = m->z;
    double m_r = L->mk + L->slope * (t - L->tk);
    double w_m = m->i * z[1], T, i_rms = 0.0, Pel = 0.0, u, f;
    supply(m, t, &u, &f);
    if (!m->dq) {
        T = kloss_torque(m, w_m, t);
    } else {
        double c[4];
        dq_currents(m, z + 2, c);
        T = 1.5 * m->p * (z[2] * c[1] - z[3] * c[0]);
        i_rms = hypot(c[0], c[1]) / sqrt(2.0);
        Pel = 1.5 * u * m->v_peak * c[0];
    }
    double psi = z[0], pd = z[1], pdd = (m->i * T + m_r) / m->J;
    crank_publish(v, m->l, psi, pd, pdd);
    double ws = f * m->w_sync;
    v[VR_w_motor] = w_m;
    v[VR_n_motor] = w_m / RPM;
    v[VR_slip] = ws > 0.0 ? (ws - w_m) / ws : 0.0;
    v[VR_T_motor] = T;
    v[VR_I_motor] = i_rms;
    v[VR_P_el] = Pel;
    v[VR_P_motor] = T * w_m;
    v[VR_W_motor] = z[m->nz - 1];
    v[VR_E_drive] = 0.5 * m->J * py_square(z[1]);
}

/* ===================================================================== the dq fit */
/* (torque, cos phi) of the T circuit in steady state at slip s (_phasor_steady_state) */
static void phasor_state(double Rs, double Rr, double Lsig, double Lm, double p, double U, double w, double s,
                         double *T, double *cos_phi)
{
    double complex Zs = Rs + I * w * Lsig, Zm = I * w * Lm, Zr = Rr / s + I * w * Lsig;
    double complex Z = Zs + Zm * Zr / (Zm + Zr);
    double complex Is = U / Z, Ir = Is * Zm / (Zm + Zr);
    *T = 3.0 * py_square(cabs(Ir)) * Rr / s / (w / p);
    *cos_phi = cos(atan2(cimag(Z), creal(Z)));
}

/* maximum motoring torque (_phasor_breakdown) */
static double phasor_breakdown(double Rs, double Lsig, double Lm, double p, double U, double w)
{
    double complex Zs = Rs + I * w * Lsig, Zm = I * w * Lm;
    double V = cabs(U * Zm / (Zs + Zm));
    double complex Zth = Zs * Zm / (Zs + Zm);
    double R = creal(Zth), X = cimag(Zth) + w * Lsig, Z = hypot(R, X);
    return 3.0 * py_square(V) / (2.0 * (w / p) * (R + Z));
}

typedef struct {
    double Rs, p, U, w, sn, Tn, Tb, pf;
} fit_data;

static void fit_residual(const fit_data *d, const double x[3], double r[3])
{
    double Rr = exp(x[0]), Lsig = exp(x[1]), Lm = exp(x[2]), T, c;
    phasor_state(d->Rs, Rr, Lsig, Lm, d->p, d->U, d->w, d->sn, &T, &c);
    r[0] = T / d->Tn - 1.0;
    r[1] = phasor_breakdown(d->Rs, Lsig, Lm, d->p, d->U, d->w) / d->Tb - 1.0;
    r[2] = c / d->pf - 1.0;
}

/* Newton's method on the three conditions in log parameters; 1 when converged */
static int fit_dq(const fit_data *d, double x[3])
{
    double r[3];
    for (int it = 0; it < 100; it++) {
        fit_residual(d, x, r);
        if (!(isfinite(r[0]) && isfinite(r[1]) && isfinite(r[2]))) return 0;
        double J[3][3], rp[3], rm[3];
        for (int j = 0; j < 3; j++) { /* central differences */
            double xp[3] = {x[0], x[1], x[2]}, xm[3] = {x[0], x[1], x[2]}, e = 1e-6;
            xp[j] += e;
            xm[j] -= e;
            fit_residual(d, xp, rp);
            fit_residual(d, xm, rm);
            for (int i = 0; i < 3; i++) J[i][j] = (rp[i] - rm[i]) / (2.0 * e);
        }
        /* solve J dx = -r (Cramer: 3x3) */
        double det = J[0][0] * (J[1][1] * J[2][2] - J[1][2] * J[2][1]) - J[0][1] * (J[1][0] * J[2][2] - J[1][2] * J[2][0])
                     + J[0][2] * (J[1][0] * J[2][1] - J[1][1] * J[2][0]);
        if (!(fabs(det) > 0.0 && isfinite(det))) return 0;
        double dx[3];
        for (int k = 0; k < 3; k++) {
            double M[3][3];
            memcpy(M, J, sizeof M);
            for (int i = 0; i < 3; i++) M[i][k] = -r[i];
            dx[k] = (M[0][0] * (M[1][1] * M[2][2] - M[1][2] * M[2][1]) - M[0][1] * (M[1][0] * M[2][2] - M[1][2] * M[2][0])
                     + M[0][2] * (M[1][0] * M[2][1] - M[1][1] * M[2][0])) / det;
        }
        double step = 1.0; /* damped: never more than a factor e per iteration */
        for (int k = 0; k < 3; k++) step = fmin(step, 1.0 / fmax(fabs(dx[k]), 1e-300));
        for (int k = 0; k < 3; k++) x[k] += step * dx[k];
        if (fmax(fabs(dx[0]), fmax(fabs(dx[1]), fabs(dx[2]))) < 1e-15) break;
    }
    fit_residual(d, x, r);
    return fmax(fabs(r[0]), fmax(fabs(r[1]), fabs(r[2]))) <= 1e-9;
}

/* ===================================================================== setup */
static fmi2Status fail(fmu_instance *fi, const char *msg)
{
    fmu_log(fi, fmi2Error, "InductionMotor '%s': initialisation failed: %s", fmu_instance_name(fi), msg);
    return fmi2Error;
}

/* the physics' checks (motor._number/_positive/_non_negative/_fraction), with the FMU's names */
static int number_ok(fmu_instance *fi, const char *name, double x, const char *unit, int kind)
{
    char msg[200], a[32];
    const char *what = NULL;
    if (!isfinite(x)) what = "finite";
    else if (kind == 1 && !(x > 0.0)) what = "positive";
    else if (kind == 2 && !(x >= 0.0)) what = "non-negative";
    if (!what) return 1;
    snprintf(msg, sizeof msg, "%s must be %s, got %s = %s %s", name, what, name, fmu_repr(x, a), unit);
    fail(fi, msg);
    return 0;
}

static int fraction_ok(fmu_instance *fi, const char *name, double x, int lo_open, int hi_open)
{
    char msg[200], a[32];
    if (!isfinite(x)) {
        snprintf(msg, sizeof msg, "%s must be finite, got %s = %s 1", name, name, fmu_repr(x, a));
        fail(fi, msg);
        return 0;
    }
    int lo = lo_open ? x > 0.0 : x >= 0.0, hi = hi_open ? x < 1.0 : x <= 1.0;
    if (lo && hi) return 1;
    snprintf(msg, sizeof msg, "%s must lie in %s, %s, got %s = %s", name, lo_open ? "(0" : "[0", hi_open ? "1)" : "1]",
             name, fmu_repr(x, a));
    fail(fi, msg);
    return 0;
}

static fmi2Status setup(fmu_instance *fi, void *data, double *v, double t)
{
    induction_motor *m = data;
    char msg[512], a[32], b[32], c[32];
    double Pn = v[VR_P_rated], nn = v[VR_n_rated], Un = v[VR_U_rated], fn = v[VR_f_rated], In = v[VR_I_rated];
    double pf = v[VR_cos_phi], eta = v[VR_eta], kb = v[VR_Tb_ratio], Jr = v[VR_J_rotor], share = v[VR_Rs_share];
    int start = (int)v[VR_start_mode], model = (int)v[VR_model], m_input = (int)v[VR_M_input];
    if (!number_ok(fi, "P_rated", Pn, "W", 1) || !number_ok(fi, "n_rated", nn, "1/min", 1) ||
        !number_ok(fi, "U_rated", Un, "V", 1) || !number_ok(fi, "f_rated", fn, "Hz", 1) ||
        !number_ok(fi, "I_rated", In, "A", 1) || !number_ok(fi, "J_rotor", Jr, "kg m2", 1) ||
        !number_ok(fi, "ramp_time", v[VR_ramp_time], "s", 1))
        return fmi2Error;
    if (v[VR_pole_pairs] < 1.0) {
        snprintf(msg, sizeof msg, "pole_pairs must be a positive integer (2 for a 4-pole motor), got pole_pairs = %.0f",
                 v[VR_pole_pairs]);
        return fail(fi, msg);
    }
    if (!fraction_ok(fi, "cos_phi", pf, 1, 0) || !fraction_ok(fi, "eta", eta, 1, 0) ||
        !fraction_ok(fi, "u_start", v[VR_u_start], 0, 0) || !fraction_ok(fi, "f_start", v[VR_f_start], 0, 1) ||
        !fraction_ok(fi, "Rs_share", share, 0, 1) || !number_ok(fi, "Tb_ratio", kb, "1", 0))
        return fmi2Error;
    if (!(kb > 1.0)) {
        snprintf(msg, sizeof msg, "Tb_ratio Tb/Tn must be larger than 1 (Kloss's formula has no rated point "
                 "otherwise), got Tb_ratio = %s", fmu_repr(kb, a));
        return fail(fi, msg);
    }
    double p = v[VR_pole_pairs];
    double n_sync = 60.0 * fn / p;
    if (!(nn < n_sync)) {
        snprintf(msg, sizeof msg, "n_rated must be below the synchronous speed 60 f / p = %g 1/min (a motor runs "
                 "with positive slip), got n_rated = %s 1/min with f_rated = %g Hz, pole_pairs = %.0f",
                 n_sync, fmu_repr(nn, a), fn, p);
        return fail(fi, msg);
    }
    if (start < 1 || start > 3) {
        snprintf(msg, sizeof msg, "start_mode must be one of [1, 2, 3] (1 = dol, 2 = voltage_ramp, "
                 "3 = frequency_ramp), got %d", start);
        return fail(fi, msg);
    }
    double p_in = sqrt(3.0) * Un * In * pf, ratio = Pn / (eta * p_in);
    if (!(0.85 <= ratio && ratio <= 1.15)) {
        snprintf(msg, sizeof msg, "the rated values are inconsistent: Pn / eta = %.4g W but sqrt(3) Un In cos phi = "
                 "%.4g W (expected within 15 %%); check units: P_rated = %s W, U_rated = %s V, I_rated = %s A",
                 Pn / eta, p_in, fmu_repr(Pn, a), fmu_repr(Un, b), fmu_repr(In, c));
        return fail(fi, msg);
    }
    if (!number_ok(fi, "i", v[VR_i], "1", 1) || !number_ok(fi, "J_crank", v[VR_J_crank], "kg m2", 2) ||
        !number_ok(fi, "m_platform", v[VR_m_platform], "kg", 2) || !number_ok(fi, "l", v[VR_l], "m", 1))
        return fmi2Error;
    if (model != 1 && model != 2) {
        snprintf(msg, sizeof msg, "model must be one of [1, 2] (1 = kloss, 2 = dq), got %d", model);
        return fail(fi, msg);
    }
    if (m_input != 1 && m_input != 2) {
        snprintf(msg, sizeof msg, "M_input must be one of [1, 2] (1 = hold, 2 = linear), got %d", m_input);
        return fail(fi, msg);
    }
    double tol = v[VR_tolerance];
    if (!(isfinite(tol) && 1e-15 <= tol && tol <= 1e-1)) {
        snprintf(msg, sizeof msg, "tolerance must be within [1e-15, 0.1], got %s", fmu_repr(tol, a));
        return fail(fi, msg);
    }
    /* the motor's constants (InductionMotor properties) */
    m->p = p;
    m->fn = fn;
    m->start = start;
    m->ramp_time = v[VR_ramp_time];
    m->u_start = v[VR_u_start];
    m->f_start = v[VR_f_start];
    m->w_sync = 2.0 * M_PI * fn / p;
    double wn = nn * RPM, sn = 1.0 - wn / m->w_sync, Tn = Pn / wn;
    m->Tb = kb * Tn;
    m->sb = sn * (kb + sqrt(kb * kb - 1.0));
    m->v_peak = sqrt(2.0 / 3.0) * Un;
    m->dq = model == 2;
    /* the dq parameters, fitted to the datasheet (InductionMotor._fit_dq); the Python flavour
     * fits them whatever the model, so both refuse the same datasheets */
    {
        fit_data d;
        d.p = p;
        d.w = 2.0 * M_PI * fn;
        d.U = Un / sqrt(3.0);
        d.sn = sn;
        d.Tn = Tn;
        d.Tb = m->Tb;
        d.pf = pf;
        double p_loss = Pn / eta - Pn, p_cu_rotor = sn * Tn * m->w_sync;
        d.Rs = share * fmax(p_loss - p_cu_rotor, 0.0) / (3.0 * py_square(In));
        double X = 3.0 * d.U * d.U / (2.0 * m->w_sync * m->Tb);
        double x[3] = {log(m->sb * X), log(X / (2.0 * d.w)),
                       log(d.U / (In * sqrt(fmax(1.0 - py_square(pf), 1e-6))) / d.w)};
        if (!fit_dq(&d, x)) {
            snprintf(msg, sizeof msg, "no dq parameters reproduce the rated point and breakdown torque with "
                     "Rs_share = %s and cos_phi = %s; lower Rs_share", fmu_repr(share, a), fmu_repr(pf, b));
            return fail(fi, msg);
        }
        m->Rs = d.Rs;
        m->Rr = exp(x[0]);
        m->Lsig = exp(x[1]);
        m->Lm = exp(x[2]);
    }
    /* gear, shaft, crank (CrankDrive) */
    m->i = v[VR_i];
    m->l = v[VR_l];
    m->J = v[VR_J_crank] + v[VR_m_platform] * py_square(m->l) + py_square(m->i) * Jr;
    m->linear_load = m_input == 2;
    m->nz = m->dq ? 7 : 3;
    /* DOP853 with the FMU's scales */
    bm_problem *P = &m->P;
    const bm_tableau *tab = &BM_TABLEAUS[0];
    memset(P, 0, sizeof *P);
    P->form = BM_GENERIC;
    P->ny = m->nz;
    P->ns = tab->ns; P->order = tab->order; P->adaptive = tab->adaptive; P->has_e3 = tab->has_e3;
    memcpy(P->A, tab->A, sizeof P->A);
    memcpy(P->B, tab->B, sizeof P->B);
    memcpy(P->C, tab->C, sizeof P->C);
    memcpy(P->E, tab->E, sizeof P->E);
    memcpy(P->E3, tab->E3, sizeof P->E3);
    P->tol = tol; P->h_fixed = 1e-3; P->h_max = INFINITY; P->max_steps = MAX_INTERNAL_STEPS;
    double w_scale = m->w_sync / m->i, flux = m->v_peak / (2.0 * M_PI * fn);
    P->scale[0] = 1.0;
    P->scale[1] = w_scale;
    for (int k = 2; k < m->nz - 1; k++) P->scale[k] = flux;
    P->scale[m->nz - 1] = bm_pymax(1.0, 0.5 * m->J * py_square(w_scale));
    for (int k = 0; k < m->nz; k++) P->tols[k] = tol * P->scale[k];
    bm_tab_make(P, &m->T);
    if (!isfinite(v[VR_M_reaction])) {
        snprintf(msg, sizeof msg, "input M_reaction must be finite, got %s N.m", fmu_repr(v[VR_M_reaction], a));
        return fail(fi, msg);
    }
    memset(m->z, 0, sizeof m->z);
    m->h = NAN;
    m->n_samples = 1;
    m->st[0] = t;
    m->sm[0] = v[VR_M_reaction];
    load_ctx L = make_load(m, 0, NAN, NAN, t, v[VR_M_reaction]);
    publish(m, &L, t, v);
    return fmi2OK;
}

/* ===================================================================== step */
static fmi2Status step(fmu_instance *fi, void *data, double *v, double t, double t_end)
{
    induction_motor *m = data;
    char a[32], b[32];
    double m_r = v[VR_M_reaction];
    if (!isfinite(m_r)) {
        fmu_log(fi, fmi2Discard, "InductionMotor '%s': input M_reaction must be finite, got %s at t = %.9g s; step "
                "refused, last good state kept", fmu_instance_name(fi), fmu_repr(m_r, a), t);
        return fmi2Discard;
    }
    /* the slope of M_reaction from the latest sample at least half a step back (a very
     * short previous step would otherwise amplify the input's noise into the slope), else
     * from the latest one before t */
    double back = t - 0.5 * (t_end - t), tp = NAN, mp = NAN;
    int has_prev = 0;
    for (int k = 0; k < m->n_samples; k++)
        if (m->st[k] <= back) {
            tp = m->st[k];
            mp = m->sm[k];
            has_prev = 1;
        }
    for (int k = 0; !has_prev && k < m->n_samples; k++)
        if (m->st[k] < t) { /* the latest before t: keep scanning */
            tp = m->st[k];
            mp = m->sm[k];
        }
    if (!has_prev && tp == tp) has_prev = 1;
    load_ctx L = make_load(m, has_prev, tp, mp, t, m_r);
    /* keep the last three samples before t and (t, M_reaction) */
    double kt[4], km[4];
    int nk = 0;
    for (int k = 0; k < m->n_samples; k++)
        if (m->st[k] < t) {
            if (nk == 3) {
                memmove(kt, kt + 1, 2 * sizeof(double));
                memmove(km, km + 1, 2 * sizeof(double));
                nk = 2;
            }
            kt[nk] = m->st[k];
            km[nk] = m->sm[k];
            nk++;
        }
    kt[nk] = t;
    km[nk] = m_r;
    nk++;
    memcpy(m->st, kt, (size_t)nk * sizeof(double));
    memcpy(m->sm, km, (size_t)nk * sizeof(double));
    m->n_samples = nk;
    double hh = m->h;
    if (!(hh > 0.0 && isfinite(hh))) {
        double f0[BM_NYMAX];
        drive_rhs(&m->P, &L, t, m->z, f0);
        if (!bm_all_finite(f0, m->nz)) goto failed;
        hh = bm_initial_step_np(&m->P, drive_rhs, &L, t, m->z, f0, t_end - t);
    }
    bm_stats stats = {0, 0, 0};
    if (!bm_advance(&m->P, &m->T, drive_rhs, &L, t, m->z, t_end, &hh, &stats)) goto failed;
    m->h = hh;
    publish(m, &L, t_end, v);
    return fmi2OK;
failed:
    fmu_log(fi, fmi2Discard, "InductionMotor '%s': step from t = %.9g s refused, last good state kept: DOP853 could not "
            "reach t = %s s (non-finite values, step size underflow or more than 20000 internal steps)",
            fmu_instance_name(fi), t, fmu_repr(t_end, b));
    return fmi2Discard;
}

/* ===================================================================== restored states */
static fmi2Status check(fmu_instance *fi, const void *data, const double *v)
{
    const induction_motor *m = data;
    (void)v;
    int ok = m->n_samples >= 1 && m->n_samples <= 4 && bm_all_finite(m->z, m->nz);
    for (int k = 0; ok && k < m->n_samples; k++) ok = isfinite(m->st[k]) && isfinite(m->sm[k]);
    if (ok) return fmi2OK;
    fmu_log(fi, fmi2Error, "InductionMotor '%s': FMU state refused: its drive state or load samples are not valid",
            fmu_instance_name(fi));
    return fmi2Error;
}

/* ===================================================================== Model Exchange
 * The importer integrates z (the states s_psi .. s_W_motor; with Kloss the four fluxes are
 * not used: their derivatives are 0) with M_reaction as set at every call (held at that
 * instant: drive_rhs with no slope); time events where the supply is switched on (t = 0) and
 * where a ramp ends (t = ramp_time). */
static const int ME_X[7] = {VR_s_psi, VR_s_psi_dot, VR_s_flux_sd, VR_s_flux_sq, VR_s_flux_rd, VR_s_flux_rq,
                            VR_s_W_motor};
static const int ME_DX[7] = {VR_der_s_psi, VR_der_s_psi_dot, VR_der_s_flux_sd, VR_der_s_flux_sq,
                             VR_der_s_flux_rd, VR_der_s_flux_rq, VR_der_s_W_motor};

/* the index in z of ME state k (Kloss: psi, psi', W; dq: all seven), or -1 when unused */
static int me_index(const induction_motor *m, int k)
{
    if (m->dq || k < 2) return k;
    return k == 6 ? 2 : -1;
}

static fmi2Status me_start(fmu_instance *fi, void *data, double *v, double t)
{
    const induction_motor *m = data;
    (void)fi;
    (void)t;
    for (int k = 0; k < 7; k++) v[ME_X[k]] = me_index(m, k) < 0 ? 0.0 : m->z[me_index(m, k)];
    return fmi2OK;
}

static fmi2Status me_eval(fmu_instance *fi, void *data, double *v, double t, double *zi)
{
    induction_motor *m = data;
    double dz[NZ_MAX];
    (void)zi;
    if (!isfinite(v[VR_M_reaction])) {
        char a[32], b[32];
        fmu_log(fi, fmi2Error, "InductionMotor '%s': input M_reaction must be finite, got %s N.m at t = %s s",
                fmu_instance_name(fi), fmu_repr(v[VR_M_reaction], a), fmu_repr(t, b));
        return fmi2Error;
    }
    for (int k = 0; k < 7; k++)
        if (me_index(m, k) >= 0) m->z[me_index(m, k)] = v[ME_X[k]];
    load_ctx L = make_load(m, 0, NAN, NAN, t, v[VR_M_reaction]);
    drive_rhs(&m->P, &L, t, m->z, dz);
    for (int k = 0; k < 7; k++) v[ME_DX[k]] = me_index(m, k) < 0 ? 0.0 : dz[me_index(m, k)];
    publish(m, &L, t, v);
    return fmi2OK;
}

static double next_time(const void *data, double t)
{
    const induction_motor *m = data;
    return t < 0.0 ? 0.0 : m->start != 1 && t < m->ramp_time ? m->ramp_time : INFINITY;
}

static const fmu_me ME = {
    FMU_N_STATES, FMU_N_INDICATORS, FMU_STATE_VRS, FMU_DERIVATIVE_VRS, FMU_STATE_NOMINALS, FMU_INDICATOR_VRS,
    me_start, me_eval, NULL, next_time,
};

const fmu_model FMU_MODEL = {
    FMU_IDENTIFIER, FMU_GUID, FMU_N_VARS, FMU_VARIABLES,
    sizeof(induction_motor), offsetof(induction_motor, z),
    setup, step, check, NULL, &ME,
};
