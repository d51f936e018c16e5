/* drive_models/fig1drive.c: the native Fig1Drive FMU's model (the FMI plumbing is
 * fmu_src/native/fmi2.c; the variables come from ballmill/fmi/interface.py through the
 * generated Fig1Drive_interface.h).
 *
 * The drives of the paper's Fig. 1 machine as ballmill.physics.turning.drive.Fig1Drive
 * computes them (kinematics of motions.Fig1Machine, loads and torques of drive.py), in
 * the same operation order, so both flavours give the same values bit for bit
 * (drive_models/fig1drive_fmu.py): the frame turns about its shaft e (x1 or z1 through
 * O1) by phi (constant speed, or a start-up law of crank_law.h), the cranks carry the
 * platform point O = R_e(phi) (c + l u(psi)) on a circle relative to the frame, the
 * chamber's orientation is R_e(phi). From the ball's wrench (F, M_O1):
 *     M_frame = e . M_O1,   M_crank = T . F,   T = R_e(phi) da/dpsi,
 *     T_frame = J_frame phi'' + J_crank k_e (psi'' + k_e phi'') + e . (O x m_p (a_O + g e_z)) - M_frame,
 *     T_crank = J_crank (psi'' + k_e phi'') + m_p (a_O + g e_z) . T - M_crank,
 *     P_frame = T_frame phi',  P_crank = T_crank psi'.
 */
#include <math.h>

#include "fmu_model.h"
#include "Fig1Drive_interface.h"
#include "crank_law.h"

enum { FRAME_CONSTANT = 0 };   /* frame_law 0; 1..4 are crank_law.h's shapes */
enum { SHAFT_X = 1, SHAFT_Z = 2 };
enum { ARR_PERPENDICULAR = 1, ARR_PARALLEL = 2 };

typedef struct {
    int frame_law, crank_law;
    int vertical; /* the shaft is z1 */
    int yz;       /* the crank circle lies in the frame's yz plane (else xy) */
    double w_frame, t0_frame, w0, t0, l, centre[3];
    double j_frame, j_crank, m_p, g, k_e;
    double unused; /* dynamic state: none beyond the plumbing's time */
} fig1_drive;

/* Fig1Drive.outputs at t, from the inputs in v */
static void publish(const fig1_drive *m, double *v, double t)
{
    double ph[3], ps[3], a[3], ap[3], app[3], A[3], T[3], U[3], vA[3], aA[3];
    if (m->frame_law == FRAME_CONSTANT) { /* ConstantSpeed(w).angle */
        ph[0] = 0.0 + m->w_frame * t; ph[1] = m->w_frame; ph[2] = 0.0;
    } else {
        startup_angle(m->frame_law, m->w_frame, m->t0_frame, t, ph);
    }
    startup_angle(m->crank_law, m->w0, m->t0, t, ps);
    double phd = ph[1], phdd = ph[2], psd = ps[1], psdd = ps[2];
    double c = cos(ph[0]), s = sin(ph[0]);
    double cp = cos(ps[0]), sp = sin(ps[0]);
    double l = m->l, ox = m->centre[0], oy = m->centre[1], oz = m->centre[2];
    if (m->yz) {
        a[0] = ox; a[1] = oy + l * cp; a[2] = oz + l * sp;
        ap[0] = 0.0; ap[1] = -l * sp; ap[2] = l * cp;
        app[0] = 0.0; app[1] = -l * cp; app[2] = -l * sp;
    } else {
        a[0] = ox + l * cp; a[1] = oy + l * sp; a[2] = oz;
        ap[0] = -l * sp; ap[1] = l * cp; ap[2] = 0.0;
        app[0] = -l * cp; app[1] = -l * sp; app[2] = 0.0;
    }
    double Q[9] = {0.0};
    if (m->vertical) {
        A[0] = c * a[0] - s * a[1]; A[1] = s * a[0] + c * a[1]; A[2] = a[2];
        T[0] = c * ap[0] - s * ap[1]; T[1] = s * ap[0] + c * ap[1]; T[2] = ap[2];
        U[0] = c * app[0] - s * app[1]; U[1] = s * app[0] + c * app[1]; U[2] = app[2];
        vA[0] = -phd * A[1] + psd * T[0]; vA[1] = phd * A[0] + psd * T[1]; vA[2] = psd * T[2];
        aA[0] = -phdd * A[1] - phd * phd * A[0] - 2.0 * phd * psd * T[1] + psd * psd * U[0] + psdd * T[0];
        aA[1] = phdd * A[0] - phd * phd * A[1] + 2.0 * phd * psd * T[0] + psd * psd * U[1] + psdd * T[1];
        aA[2] = psd * psd * U[2] + psdd * T[2];
        v[VR_Omega_x] = 0.0; v[VR_Omega_y] = 0.0; v[VR_Omega_z] = phd;
        v[VR_Omega_dot_x] = 0.0; v[VR_Omega_dot_y] = 0.0; v[VR_Omega_dot_z] = phdd;
        Q[0] = c; Q[1] = -s; Q[3] = s; Q[4] = c; Q[8] = 1.0;
    } else {
        A[0] = a[0]; A[1] = c * a[1] - s * a[2]; A[2] = s * a[1] + c * a[2];
        T[0] = ap[0]; T[1] = c * ap[1] - s * ap[2]; T[2] = s * ap[1] + c * ap[2];
        U[0] = app[0]; U[1] = c * app[1] - s * app[2]; U[2] = s * app[1] + c * app[2];
        vA[0] = psd * T[0]; vA[1] = -phd * A[2] + psd * T[1]; vA[2] = phd * A[1] + psd * T[2];
        aA[0] = psd * psd * U[0] + psdd * T[0];
        aA[1] = -phdd * A[2] - phd * phd * A[1] - 2.0 * phd * psd * T[2] + psd * psd * U[1] + psdd * T[1];
        aA[2] = phdd * A[1] - phd * phd * A[2] + 2.0 * phd * psd * T[1] + psd * psd * U[2] + psdd * T[2];
        v[VR_Omega_x] = phd; v[VR_Omega_y] = 0.0; v[VR_Omega_z] = 0.0;
        v[VR_Omega_dot_x] = phdd; v[VR_Omega_dot_y] = 0.0; v[VR_Omega_dot_z] = 0.0;
        Q[0] = 1.0; Q[4] = c; Q[5] = -s; Q[7] = s; Q[8] = c;
    }
    v[VR_phi] = ph[0]; v[VR_phi_dot] = phd; v[VR_phi_ddot] = phdd;
    v[VR_psi] = ps[0]; v[VR_psi_dot] = psd; v[VR_psi_ddot] = psdd;
    v[VR_x1O] = A[0]; v[VR_y1O] = A[1]; v[VR_z1O] = A[2];
    v[VR_vx1O] = vA[0]; v[VR_vy1O] = vA[1]; v[VR_vz1O] = vA[2];
    v[VR_ax1O] = aA[0]; v[VR_ay1O] = aA[1]; v[VR_az1O] = aA[2];
    v[VR_Q11] = Q[0]; v[VR_Q12] = Q[1]; v[VR_Q13] = Q[2];
    v[VR_Q21] = Q[3]; v[VR_Q22] = Q[4]; v[VR_Q23] = Q[5];
    v[VR_Q31] = Q[6]; v[VR_Q32] = Q[7]; v[VR_Q33] = Q[8];

    /* the loads: reaction moments from the ball's wrench, then the drives' torques */
    double M_frame = m->vertical ? v[VR_MO1z] : v[VR_MO1x];
    double M_crank = T[0] * v[VR_Fx] + T[1] * v[VR_Fy] + T[2] * v[VR_Fz];
    double bx = m->m_p * aA[0], by = m->m_p * aA[1], bz = m->m_p * (aA[2] + m->g);
    double plat_frame = m->vertical ? A[0] * by - A[1] * bx : A[1] * bz - A[2] * by;
    double crank_acc = psdd + m->k_e * phdd;
    double T_crank = (m->j_crank * crank_acc + (bx * T[0] + by * T[1] + bz * T[2])) - M_crank;
    double T_frame = ((m->j_frame * phdd + m->j_crank * m->k_e * crank_acc) + plat_frame) - M_frame;
    v[VR_M_frame] = M_frame;
    v[VR_M_crank] = M_crank;
    v[VR_T_frame] = T_frame;
    v[VR_T_crank] = T_crank;
    v[VR_P_frame] = T_frame * phd;
    v[VR_P_crank] = T_crank * psd;
}

/* 1 and the first non-finite wrench input in name/value, or 0 when all are finite */
static int bad_wrench(const double *v, const char **name, double *value)
{
    static const struct { const char *name; int vr; } in[] = {
        {"Fx", VR_Fx}, {"Fy", VR_Fy}, {"Fz", VR_Fz}, {"MO1x", VR_MO1x}, {"MO1y", VR_MO1y}, {"MO1z", VR_MO1z},
    };
    for (size_t i = 0; i < sizeof in / sizeof in[0]; i++) {
        if (!isfinite(v[in[i].vr])) {
            *name = in[i].name;
            *value = v[in[i].vr];
            return 1;
        }
    }
    return 0;
}

static const char *unit_of(const char *name) { return name[0] == 'F' ? "N" : "N.m"; }

static fmi2Status setup(fmu_instance *fi, void *data, double *v, double t)
{
    fig1_drive *m = data;
    int shaft = (int)v[VR_shaft], arrangement = (int)v[VR_arrangement];
    int frame_law = (int)v[VR_frame_law], law = (int)v[VR_law];
    /* the declared bounds keep these in range (the plumbing checks them); as the Python flavour */
    if (shaft < SHAFT_X || shaft > SHAFT_Z || arrangement < ARR_PERPENDICULAR || arrangement > ARR_PARALLEL
        || frame_law < FRAME_CONSTANT || frame_law > STARTUP_QUINTIC || law < STARTUP_QUADRATIC
        || law > STARTUP_QUINTIC) {
        fmu_log(fi, fmi2Error, "Fig1Drive '%s': initialisation failed: shaft = %d (1 or 2), arrangement = %d "
                "(1 or 2), frame_law = %d (0..4), law = %d (1..4)", fmu_instance_name(fi), shaft, arrangement,
                frame_law, law);
        return fmi2Error;
    }
    const char *name;
    double value;
    if (bad_wrench(v, &name, &value)) {
        char a[32];
        fmu_log(fi, fmi2Error, "Fig1Drive '%s': initialisation failed: input %s must be finite, got %s %s",
                fmu_instance_name(fi), name, fmu_repr(value, a), unit_of(name));
        return fmi2Error;
    }
    m->frame_law = frame_law;
    m->crank_law = law;
    m->vertical = shaft == SHAFT_Z;
    m->yz = (arrangement == ARR_PARALLEL) != m->vertical;
    m->w_frame = v[VR_Omega_frame];
    m->t0_frame = v[VR_t0_frame];
    m->w0 = 2.0 * M_PI * v[VR_n0] / 60.0; /* CrankStartup.w0 */
    m->t0 = v[VR_t0];
    m->l = v[VR_l];
    m->centre[0] = v[VR_xc]; m->centre[1] = v[VR_yc]; m->centre[2] = v[VR_zc];
    m->j_frame = v[VR_J_frame];
    m->j_crank = v[VR_J_crank];
    m->m_p = v[VR_m_platform];
    m->g = v[VR_g];
    m->k_e = arrangement == ARR_PARALLEL ? 1.0 : 0.0;
    publish(m, v, t); /* the plumbing refuses non-finite outputs (check_outputs) */
    return fmi2OK;
}

static fmi2Status step(fmu_instance *fi, void *data, double *v, double t, double t_end)
{
    const char *name;
    double value;
    if (bad_wrench(v, &name, &value)) {
        char a[32], b[32];
        fmu_log(fi, fmi2Discard, "Fig1Drive '%s': input %s must be finite, got %s %s at t = %s s; step refused, "
                "last good state kept", fmu_instance_name(fi), name, fmu_repr(value, a), unit_of(name),
                fmu_repr(t, b));
        return fmi2Discard;
    }
    publish(data, v, t_end); /* the plumbing refuses non-finite outputs (check_outputs) */
    return fmi2OK;
}

/* ===================================================================== Model Exchange
 * No continuous states: publish's outputs at the time the importer sets, from the wrench as
 * set; the laws' kinks (t = 0, the cranks' t0, the frame's t0_frame) are time events. */
static fmi2Status me_eval(fmu_instance *fi, void *data, double *v, double t, double *z)
{
    const char *name;
    double value;
    (void)z;
    if (bad_wrench(v, &name, &value)) {
        char a[32], b[32];
        fmu_log(fi, fmi2Error, "Fig1Drive '%s': input %s must be finite, got %s %s at t = %s s",
                fmu_instance_name(fi), name, fmu_repr(value, a), unit_of(name), fmu_repr(t, b));
        return fmi2Error;
    }
    publish(data, v, t);
    return fmi2OK;
}

static double next_time(const void *data, double t)
{
    const fig1_drive *m = data;
    double kinks[3] = {0.0, m->t0, m->frame_law != FRAME_CONSTANT ? m->t0_frame : -INFINITY}, next = INFINITY;
    for (int i = 0; i < 3; i++)
        if (kinks[i] > t && kinks[i] < next) next = kinks[i];
    return next;
}

static const fmu_me ME = {
    FMU_N_STATES, FMU_N_INDICATORS, FMU_STATE_VRS, FMU_DERIVATIVE_VRS, FMU_STATE_NOMINALS, FMU_INDICATOR_VRS,
    NULL, me_eval, NULL, next_time,
};

const fmu_model FMU_MODEL = {
    FMU_IDENTIFIER, FMU_GUID, FMU_N_VARS, FMU_VARIABLES,
    sizeof(fig1_drive), offsetof(fig1_drive, unused),
    setup, step, NULL, NULL, &ME, /* no dynamic state to check, no feedthrough */
};
