/* drive_models/structure.c: the native Structure FMU's model: a linear structure that carries a
 * ball absorber's cavity and feels the ball. Like the drives beside it, it moves the chamber:
 * its outputs x1O .. ay1O are the cavity's absolute motion under BallInShell's input names,
 * and its inputs Fx_ball, Fy_ball take BallInShell's Fx, Fy (coupled both ways). The FMI
 * plumbing is fmu_src/native/fmi2.c; the variables come from ballmill/fmi/interface.py
 * (STRUCTURE) through the generated Structure_interface.h.
 *
 * The equations are ballmill.absorber.structure.StructureModel's, per horizontal axis and
 * mode j (up to 3; n_x >= 1, n_y >= 0):
 *     M_j q_j'' + C_j q_j' + K_j q_j = psi_j F_ext - L_j a_g + phi_j F_ball,
 *     K_j = M_j (2 pi f_j)^2, C_j = 2 zeta_j M_j (2 pi f_j),
 * F_ext = F0 sin(theta), a_g = ag0 sin(theta) + input ag, theta = 2 pi t (f_exc + sweep_rate t / 2)
 * (y: sin(theta + phase_y)). The ground's velocity and displacement are integrated from a_g,
 * and the work quadratures W_exc, W_damp, W_ball with the modes: classical RK4 in
 * ceil(H / h_max) equal steps, the inputs extrapolated over the step from the last
 * input_order + 1 communication points. Same operations in the same order as the pythonfmu
 * flavour (drive_models/structure_fmu.py), so both give the same numbers.
 *
 * Direct feedthrough: ax1O, ay1O, ax_load, ay_load, agx_total, agy_total depend on the inputs
 * at the same instant; `inputs_set` recomputes every output when inputs are set between steps.
 */
#include <math.h>
#include <string.h>

#include "fmu_model.h"
#include "Structure_interface.h"

#define MAXM 3            /* modes per axis (interface.STRUCTURE_MODES) */
#define NPAR 6            /* parameters per mode: M, f, zeta, phi, psi, L */
#define NEXTRA 7          /* x_g, v_gx, y_g, v_gy, W_exc, W_damp, W_ball */
#define NZ (4 * MAXM + NEXTRA)
#define NIN 4             /* Fx_ball, Fy_ball, ag_x, ag_y */
#define NSAMP 3

_Static_assert(VR_M_x2 == VR_M_x1 + NPAR && VR_M_x3 == VR_M_x1 + 2 * NPAR && VR_L_x1 == VR_M_x1 + 5,
               "mode parameters of x must be consecutive M, f, zeta, phi, psi, L");
_Static_assert(VR_M_y2 == VR_M_y1 + NPAR && VR_M_y3 == VR_M_y1 + 2 * NPAR && VR_L_y1 == VR_M_y1 + 5,
               "mode parameters of y must be consecutive M, f, zeta, phi, psi, L");
_Static_assert(VR_Fy_ball == VR_Fx_ball + 1 && VR_ag_x == VR_Fx_ball + 2 && VR_ag_y == VR_Fx_ball + 3,
               "inputs must be consecutive Fx_ball, Fy_ball, ag_x, ag_y");

typedef struct {
    double M, K, C, phi, psi, L;
} mode;

typedef struct {
    double t, u[NIN];
} sample;

typedef struct {
    /* configuration: built by setup from the parameters */
    int n[2], off[2], ns, order; /* modes per axis, offset of each axis's q in z, modal states */
    mode md[2][MAXM];
    double F0[2], ag0[2], f_exc, sweep_rate, phase_y, h_max;
    /* dynamic state: what FMU states carry */
    double z[NZ];
    int n_samples;
    sample samples[NSAMP]; /* the inputs at the last communication points, oldest first */
} structure;

static const int VR_MODE1[2] = {VR_M_x1, VR_M_y1};
static const int VR_POS[2] = {VR_x1O, VR_y1O}, VR_VEL[2] = {VR_vx1O, VR_vy1O}, VR_ACC[2] = {VR_ax1O, VR_ay1O};
static const int VR_Q1[2] = {VR_q_x1, VR_q_y1}, VR_REL[2] = {VR_x_rel, VR_y_rel};
static const int VR_LOAD[2] = {VR_x_load, VR_y_load}, VR_ALOAD[2] = {VR_ax_load, VR_ay_load};
static const int VR_G[2] = {VR_xg, VR_yg}, VR_VG[2] = {VR_vxg, VR_vyg}, VR_AG[2] = {VR_agx_total, VR_agy_total};
static const int VR_FEXC[2] = {VR_Fx_exc, VR_Fy_exc};

/* (F_x, F_y, a_gx, a_gy) at t for the inputs u */
static void loads(const structure *s, double t, const double u[NIN], double out[4])
{
    double th = 2.0 * M_PI * t * (s->f_exc + 0.5 * s->sweep_rate * t);
    double sx = sin(th), sy = sin(th + s->phase_y);
    out[0] = s->F0[0] * sx;
    out[1] = s->F0[1] * sy;
    out[2] = s->ag0[0] * sx + u[2];
    out[3] = s->ag0[1] * sy + u[3];
}

/* StructureModel.derivative of the modal states: dz[0 .. ns) */
static void modal_derivative(const structure *s, const double *z, const double u[NIN], const double ld[4], double *dz)
{
    for (int a = 0; a < 2; a++) {
        int off = s->off[a], n = s->n[a];
        for (int j = 0; j < n; j++) {
            const mode *m = &s->md[a][j];
            double r = (m->psi * ld[a] - m->L * ld[2 + a] - m->C * z[off + n + j] - m->K * z[off + j]) / m->M;
            dz[off + j] = z[off + n + j];
            dz[off + n + j] = r + m->phi * u[a] / m->M;
        }
    }
}

/* the whole state's derivative: modes, ground motion, work quadratures */
static void rhs(const structure *s, double t, const double *z, const double u[NIN], double *dz)
{
    double ld[4], v[2] = {0.0, 0.0}, P_exc = 0.0, P_damp = 0.0;
    int ns = s->ns;
    loads(s, t, u, ld);
    modal_derivative(s, z, u, ld, dz);
    for (int a = 0; a < 2; a++) {
        int off = s->off[a], n = s->n[a];
        for (int j = 0; j < n; j++) v[a] += s->md[a][j].phi * z[off + n + j];
    }
    for (int a = 0; a < 2; a++) {
        int off = s->off[a], n = s->n[a];
        for (int j = 0; j < n; j++) {
            const mode *m = &s->md[a][j];
            double qd = z[off + n + j];
            P_exc += qd * (m->psi * ld[a] - m->L * ld[2 + a]);
            P_damp += m->C * qd * qd;
        }
    }
    dz[ns] = z[ns + 1];
    dz[ns + 1] = ld[2];
    dz[ns + 2] = z[ns + 3];
    dz[ns + 3] = ld[3];
    dz[ns + 4] = P_exc;
    dz[ns + 5] = P_damp;
    dz[ns + 6] = u[0] * v[0] + u[1] * v[1];
}

/* the inputs at t: Lagrange polynomial through the samples (structure_fmu.extrapolate) */
static void extrapolate(const sample *smp, int n, double t, double out[NIN])
{
    for (int k = 0; k < NIN; k++) out[k] = 0.0;
    for (int i = 0; i < n; i++) {
        double w = 1.0;
        for (int j = 0; j < n; j++)
            if (j != i) w = w * (t - smp[j].t) / (smp[i].t - smp[j].t);
        for (int k = 0; k < NIN; k++) out[k] = out[k] + w * smp[i].u[k];
    }
}

/* classical RK4 from t to t_end in ceil((t_end - t) / h_max) equal steps */
static void rk4(const structure *s, double t, double t_end, double *z, const sample *smp, int n_smp)
{
    int nz = s->ns + NEXTRA;
    double steps = ceil((t_end - t) / s->h_max * (1.0 - 1e-12));
    int n = steps < 1.0 ? 1 : (int)steps;
    double h = (t_end - t) / n;
    double k1[NZ], k2[NZ], k3[NZ], k4[NZ], w[NZ], ua[NIN], um[NIN], ub[NIN];
    for (int i = 0; i < n; i++) {
        double ta = t + i * h, tb = i == n - 1 ? t_end : t + (i + 1) * h, tm = ta + 0.5 * h;
        extrapolate(smp, n_smp, ta, ua);
        extrapolate(smp, n_smp, tm, um);
        extrapolate(smp, n_smp, tb, ub);
        rhs(s, ta, z, ua, k1);
        for (int j = 0; j < nz; j++) w[j] = z[j] + 0.5 * h * k1[j];
        rhs(s, tm, w, um, k2);
        for (int j = 0; j < nz; j++) w[j] = z[j] + 0.5 * h * k2[j];
        rhs(s, tm, w, um, k3);
        for (int j = 0; j < nz; j++) w[j] = z[j] + h * k3[j];
        rhs(s, tb, w, ub, k4);
        for (int j = 0; j < nz; j++) z[j] = z[j] + h / 6.0 * (k1[j] + 2.0 * k2[j] + 2.0 * k3[j] + k4[j]);
    }
}

/* every output at t from the state z and the inputs u; 0 (v untouched) when one is not finite */
static int publish(const structure *s, double *v, double t, const double *z, const double u[NIN])
{
    double ld[4], dz[NZ], out[FMU_N_VARS];
    int set[FMU_N_VARS];
    int ns = s->ns, nset = 0;
    loads(s, t, u, ld);
    modal_derivative(s, z, u, ld, dz);
    for (int a = 0; a < 2; a++) {
        int off = s->off[a], n = s->n[a];
        double g = z[ns + 2 * a], vg = z[ns + 2 * a + 1], rel = 0.0, vrel = 0.0, acc = 0.0, load = 0.0, aload = 0.0;
        for (int j = 0; j < n; j++) rel += s->md[a][j].phi * z[off + j];
        for (int j = 0; j < n; j++) vrel += s->md[a][j].phi * z[off + n + j];
        for (int j = 0; j < n; j++) acc += s->md[a][j].phi * dz[off + n + j];
        for (int j = 0; j < n; j++) load += s->md[a][j].psi * z[off + j];
        for (int j = 0; j < n; j++) aload += s->md[a][j].psi * dz[off + n + j];
        set[nset] = VR_POS[a], out[nset++] = g + rel;
        set[nset] = VR_VEL[a], out[nset++] = vg + vrel;
        set[nset] = VR_ACC[a], out[nset++] = ld[2 + a] + acc;
        for (int j = 0; j < MAXM; j++) set[nset] = VR_Q1[a] + j, out[nset++] = j < n ? z[off + j] : 0.0;
        set[nset] = VR_REL[a], out[nset++] = rel;
        set[nset] = VR_LOAD[a], out[nset++] = load;
        set[nset] = VR_ALOAD[a], out[nset++] = ld[2 + a] + aload;
        set[nset] = VR_G[a], out[nset++] = g;
        set[nset] = VR_VG[a], out[nset++] = vg;
        set[nset] = VR_AG[a], out[nset++] = ld[2 + a];
        set[nset] = VR_FEXC[a], out[nset++] = ld[a];
    }
    double E = 0.0;
    for (int a = 0; a < 2; a++)
        for (int j = 0; j < s->n[a]; j++) {
            const mode *m = &s->md[a][j];
            double q = z[s->off[a] + j], qd = z[s->off[a] + s->n[a] + j];
            E += 0.5 * m->M * (qd * qd) + 0.5 * m->K * (q * q);
        }
    set[nset] = VR_f_inst, out[nset++] = s->f_exc + s->sweep_rate * t;
    set[nset] = VR_E, out[nset++] = E;
    set[nset] = VR_W_exc, out[nset++] = z[ns + 4];
    set[nset] = VR_W_damp, out[nset++] = z[ns + 5];
    set[nset] = VR_W_ball, out[nset++] = z[ns + 6];
    for (int i = 0; i < nset; i++)
        if (!isfinite(out[i])) return 0;
    for (int i = 0; i < nset; i++) v[set[i]] = out[i];
    return 1;
}

static void inputs_of(const double *v, double u[NIN])
{
    for (int k = 0; k < NIN; k++) u[k] = v[VR_Fx_ball + k];
}

static const char *input_name(int k)
{
    static const char *names[NIN] = {"Fx_ball", "Fy_ball", "ag_x", "ag_y"};
    return names[k];
}

static fmi2Status setup(fmu_instance *fi, void *data, double *v, double t)
{
    structure *s = data;
    char a[32];
    memset(s, 0, sizeof *s);
    s->n[0] = (int)v[VR_n_x];
    s->n[1] = (int)v[VR_n_y];
    if (s->n[0] < 1) { /* the declared bounds keep it out; as the Python flavour */
        fmu_log(fi, fmi2Error, "Structure '%s': initialisation failed: n_x must be at least 1 (the axis the "
                "structure moves in), got n_x = %d", fmu_instance_name(fi), s->n[0]);
        return fmi2Error;
    }
    s->off[0] = 0;
    s->off[1] = 2 * s->n[0];
    s->ns = 2 * (s->n[0] + s->n[1]);
    for (int ax = 0; ax < 2; ax++)
        for (int j = 0; j < s->n[ax]; j++) {
            const double *p = v + VR_MODE1[ax] + NPAR * j;
            mode *m = &s->md[ax][j];
            double omega = 2.0 * M_PI * p[1];
            m->M = p[0];
            m->K = p[0] * (omega * omega);
            m->C = 2.0 * p[2] * p[0] * omega;
            m->phi = p[3];
            m->psi = p[4];
            m->L = p[5];
            if (!(isfinite(m->K) && isfinite(m->C))) {
                fmu_log(fi, fmi2Error, "Structure '%s': initialisation failed: mode %d of axis %c (M = %s kg, "
                        "f = %g Hz) gives a non-finite stiffness or damping", fmu_instance_name(fi), j + 1,
                        "xy"[ax], fmu_repr(p[0], a), p[1]);
                return fmi2Error;
            }
        }
    s->F0[0] = v[VR_F0_x];
    s->F0[1] = v[VR_F0_y];
    s->ag0[0] = v[VR_ag0_x];
    s->ag0[1] = v[VR_ag0_y];
    s->f_exc = v[VR_f_exc];
    s->sweep_rate = v[VR_sweep_rate];
    s->phase_y = v[VR_phase_y];
    s->h_max = v[VR_h_max];
    s->order = (int)v[VR_input_order];
    double u[NIN];
    inputs_of(v, u);
    for (int k = 0; k < NIN; k++)
        if (!isfinite(u[k])) {
            fmu_log(fi, fmi2Error, "Structure '%s': initialisation failed: input %s must be finite, got %s",
                    fmu_instance_name(fi), input_name(k), fmu_repr(u[k], a));
            return fmi2Error;
        }
    s->n_samples = 1;
    s->samples[0].t = t;
    memcpy(s->samples[0].u, u, sizeof u);
    if (!publish(s, v, t, s->z, u)) {
        fmu_log(fi, fmi2Error, "Structure '%s': initialisation failed: the outputs at t = %s s are not finite",
                fmu_instance_name(fi), fmu_repr(t, a));
        return fmi2Error;
    }
    return fmi2OK;
}

static fmi2Status step(fmu_instance *fi, void *data, double *v, double t, double t_end)
{
    structure *s = data;
    char a[32], b[32];
    double u[NIN];
    inputs_of(v, u);
    for (int k = 0; k < NIN; k++)
        if (!isfinite(u[k])) {
            fmu_log(fi, fmi2Discard, "Structure '%s': input %s must be finite, got %s at t = %s s; step refused, "
                    "last good state kept", fmu_instance_name(fi), input_name(k), fmu_repr(u[k], a), fmu_repr(t, b));
            return fmi2Discard;
        }
    /* the last `order` samples before t, then the one at t (a retried step replaces its own) */
    sample smp[NSAMP];
    int n = 0;
    for (int i = 0; i < s->n_samples; i++)
        if (s->samples[i].t < t) smp[n++] = s->samples[i];
    int keep = n < s->order ? n : s->order;
    memmove(smp, smp + (n - keep), (size_t)keep * sizeof(sample));
    smp[keep].t = t;
    memcpy(smp[keep].u, u, sizeof u);
    n = keep + 1;
    double z[NZ], ue[NIN];
    memcpy(z, s->z, sizeof z);
    rk4(s, t, t_end, z, smp, n);
    extrapolate(smp, n, t_end, ue);
    if (!publish(s, v, t_end, z, ue)) {
        fmu_log(fi, fmi2Discard, "Structure '%s': step from t = %.9g s refused, last good state kept: the outputs "
                "at t = %s s would not be finite", fmu_instance_name(fi), t, fmu_repr(t_end, a));
        return fmi2Discard;
    }
    memcpy(s->z, z, sizeof z);
    memcpy(s->samples, smp, (size_t)n * sizeof(sample));
    s->n_samples = n;
    return fmi2OK;
}

static fmi2Status check(fmu_instance *fi, const void *data, const double *v)
{
    const structure *s = data;
    (void)v;
    int ok = s->n_samples >= 1 && s->n_samples <= NSAMP;
    for (int j = 0; ok && j < s->ns + NEXTRA; j++) ok = isfinite(s->z[j]);
    for (int i = 0; ok && i < s->n_samples; i++) {
        ok = isfinite(s->samples[i].t);
        for (int k = 0; ok && k < NIN; k++) ok = isfinite(s->samples[i].u[k]);
    }
    if (ok) return fmi2OK;
    fmu_log(fi, fmi2Error, "Structure '%s': FMU state refused: its modal state or input samples are not valid",
            fmu_instance_name(fi));
    return fmi2Error;
}

/* direct feedthrough: every output at t from the state and the inputs just set */
static fmi2Status inputs_set(fmu_instance *fi, void *data, double *v, double t)
{
    const structure *s = data;
    double u[NIN];
    (void)fi;
    inputs_of(v, u);
    for (int k = 0; k < NIN; k++)
        if (!isfinite(u[k])) return fmi2OK; /* the next step refuses them */
    publish(s, v, t, s->z, u);
    return fmi2OK;
}

/* ===================================================================== Model Exchange
 * The importer integrates the 19 states s_q_x1 .. s_W_ball (interface.py: every mode's q, then
 * every mode's q', the ground's motion, the work integrals; a mode beyond n_x or n_y stays 0)
 * with the inputs as set at every call. No events. With BallInShell the coupling is an
 * algebraic loop through ax1O, ay1O <- Fx_ball, Fy_ball (declared in ModelStructure/Outputs). */
#define ME_N (4 * MAXM + NEXTRA)

/* the index in z of ME state k, or -1 for a mode the structure does not have */
static int me_index(const structure *s, int k)
{
    if (k >= 4 * MAXM) return s->ns + (k - 4 * MAXM);
    int velocity = k >= 2 * MAXM, a = (k % (2 * MAXM)) / MAXM, j = k % MAXM;
    if (j >= s->n[a]) return -1;
    return s->off[a] + (velocity ? s->n[a] : 0) + j;
}

static fmi2Status me_start(fmu_instance *fi, void *data, double *v, double t)
{
    const structure *s = data;
    (void)fi;
    (void)t;
    for (int k = 0; k < ME_N; k++) v[FMU_STATE_VRS[k]] = me_index(s, k) < 0 ? 0.0 : s->z[me_index(s, k)];
    return fmi2OK;
}

static fmi2Status me_eval(fmu_instance *fi, void *data, double *v, double t, double *zi)
{
    structure *s = data;
    double u[NIN], dz[NZ];
    char a[32], b[32];
    (void)zi;
    inputs_of(v, u);
    for (int k = 0; k < NIN; k++)
        if (!isfinite(u[k])) {
            fmu_log(fi, fmi2Error, "Structure '%s': input %s must be finite, got %s at t = %s s",
                    fmu_instance_name(fi), input_name(k), fmu_repr(u[k], a), fmu_repr(t, b));
            return fmi2Error;
        }
    for (int k = 0; k < ME_N; k++)
        if (me_index(s, k) >= 0) s->z[me_index(s, k)] = v[FMU_STATE_VRS[k]];
    rhs(s, t, s->z, u, dz);
    for (int k = 0; k < ME_N; k++) v[FMU_DERIVATIVE_VRS[k]] = me_index(s, k) < 0 ? 0.0 : dz[me_index(s, k)];
    if (!publish(s, v, t, s->z, u)) {
        fmu_log(fi, fmi2Error, "Structure '%s': the outputs at t = %s s would not be finite", fmu_instance_name(fi),
                fmu_repr(t, a));
        return fmi2Error;
    }
    return fmi2OK;
}

static const fmu_me ME = {
    FMU_N_STATES, FMU_N_INDICATORS, FMU_STATE_VRS, FMU_DERIVATIVE_VRS, FMU_STATE_NOMINALS, FMU_INDICATOR_VRS,
    me_start, me_eval, NULL, NULL,
};

const fmu_model FMU_MODEL = {
    FMU_IDENTIFIER, FMU_GUID, FMU_N_VARS, FMU_VARIABLES,
    sizeof(structure), offsetof(structure, z),
    setup, step, check, inputs_set, &ME,
};
