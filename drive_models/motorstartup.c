/* drive_models/motorstartup.c: the native MotorStartup FMU's model (the FMI plumbing is
 * fmu_src/native/fmi2.c; the variables come from ballmill/fmi/interface.py through the
 * generated MotorStartup_interface.h).
 *
 * The crank start-up laws as ballmill.physics.drives.crank.CrankStartup computes them, in
 * the same operation order (crank_law.h; same values bit for bit as the pythonfmu flavour,
 * drive_models/motorstartup_fmu.py): the crank speed rises to w0 = 2 pi n0 / 60 in t0
 * along the law the parameter `law` chooses (1 = the paper's quadratic rise, 2 = S-curve,
 * 3 = linear, 4 = quintic), the platform point moves on a circle of radius l, and with
 * the ball's reaction torque M_reaction as input the drive must supply
 *     T_drive = J_total psi'' - M_reaction,  J_total = J_crank + m_platform l^2,
 *     P_drive = T_drive psi'.
 */
#include <math.h>

#include "fmu_model.h"
#include "MotorStartup_interface.h"
#include "crank_kinematics.h"
#include "crank_law.h"

typedef struct {
    double l, w0, t0, j_total; /* configuration */
    int law;                   /* STARTUP_* of crank_law.h (the pythonfmu flavour's LAWS) */
    double unused;             /* dynamic state: none beyond the plumbing's time */
} motor_startup;

/* the outputs at t, from the input M_reaction */
static void publish(const motor_startup *m, double *v, double t)
{
    double a[3];
    startup_angle(m->law, m->w0, m->t0, t, a);
    double psi = a[0], wd = a[1], wdd = a[2];
    crank_publish(v, m->l, psi, wd, wdd);
    v[VR_T_drive] = m->j_total * wdd - v[VR_M_reaction];
    v[VR_P_drive] = v[VR_T_drive] * wd;
}

static fmi2Status refuse(fmu_instance *fi, const char *name, double value, const char *unit, const char *expected)
{
    char a[32];
    fmu_log(fi, fmi2Error, "MotorStartup '%s': initialisation failed: %s must be %s, got %s = %s %s",
            fmu_instance_name(fi), name, expected, name, fmu_repr(value, a), unit);
    return fmi2Error;
}

static fmi2Status setup(fmu_instance *fi, void *data, double *v, double t)
{
    motor_startup *m = data;
    double l = v[VR_l], n0 = v[VR_n0], t0 = v[VR_t0];
    if (!(isfinite(l) && l > 0.0)) return refuse(fi, "l", l, "m", "positive and finite");
    if (!(isfinite(n0) && n0 >= 0.0)) return refuse(fi, "n0", n0, "1/min", "non-negative and finite");
    if (!(isfinite(t0) && t0 > 0.0)) return refuse(fi, "t0", t0, "s", "positive and finite");
    if (!(isfinite(v[VR_m_platform]) && v[VR_m_platform] >= 0.0))
        return refuse(fi, "m_platform", v[VR_m_platform], "kg", "non-negative and finite");
    if (!(isfinite(v[VR_J_crank]) && v[VR_J_crank] >= 0.0))
        return refuse(fi, "J_crank", v[VR_J_crank], "kg.m2", "non-negative and finite");
    int law = (int)v[VR_law];
    if (law < STARTUP_QUADRATIC || law > STARTUP_QUINTIC) { /* the declared bounds keep it out; as the Python flavour */
        fmu_log(fi, fmi2Error, "MotorStartup '%s': initialisation failed: law must be one of [1, 2, 3, 4] "
                "(1 = quadratic, 2 = scurve, 3 = linear, 4 = quintic), got %d", fmu_instance_name(fi), law);
        return fmi2Error;
    }
    m->law = law;
    m->l = l;
    m->w0 = 2.0 * M_PI * n0 / 60.0;
    m->t0 = t0;
    m->j_total = v[VR_J_crank] + v[VR_m_platform] * (l * l);
    if (!isfinite(m->w0) || !isfinite(m->j_total) || !isfinite(2.0 * m->w0 / t0)) {
        char a[32], b[32], c[32];
        fmu_log(fi, fmi2Error, "MotorStartup '%s': initialisation failed: l = %s m, n0 = %s 1/min, t0 = %s s "
                "give a non-finite crank acceleration or inertia", fmu_instance_name(fi), fmu_repr(l, a),
                fmu_repr(n0, b), fmu_repr(t0, c));
        return fmi2Error;
    }
    if (!isfinite(v[VR_M_reaction])) {
        char a[32];
        fmu_log(fi, fmi2Error, "MotorStartup '%s': initialisation failed: input M_reaction must be finite, got %s N.m",
                fmu_instance_name(fi), fmu_repr(v[VR_M_reaction], a));
        return fmi2Error;
    }
    publish(m, v, t);
    return fmi2OK;
}

static fmi2Status step(fmu_instance *fi, void *data, double *v, double t, double t_end)
{
    if (!isfinite(v[VR_M_reaction])) {
        char a[32], b[32];
        fmu_log(fi, fmi2Discard, "MotorStartup '%s': input M_reaction must be finite, got %s at t = %s s; "
                "step refused", fmu_instance_name(fi), fmu_repr(v[VR_M_reaction], a), fmu_repr(t, b));
        return fmi2Discard;
    }
    publish(data, v, t_end);
    return fmi2OK;
}

/* direct feedthrough: T_drive and P_drive follow M_reaction set between steps (publish's
 * arithmetic at the instance's time); left as they are if they would not be finite (the
 * next step refuses such an input or output) */
static fmi2Status inputs_set(fmu_instance *fi, void *data, double *v, double t)
{
    const motor_startup *m = data;
    (void)fi;
    (void)t;
    double torque = m->j_total * v[VR_psi_ddot] - v[VR_M_reaction];
    double power = torque * v[VR_psi_dot];
    if (isfinite(torque) && isfinite(power)) {
        v[VR_T_drive] = torque;
        v[VR_P_drive] = power;
    }
    return fmi2OK;
}

/* ===================================================================== Model Exchange
 * No continuous states: the outputs are publish's at the time the importer sets, from the
 * input M_reaction as set; the law's kinks (t = 0 where the rise starts, t = t0 where it
 * ends: the acceleration or the jerk jumps) are time events. */
static fmi2Status me_eval(fmu_instance *fi, void *data, double *v, double t, double *z)
{
    (void)z;
    if (!isfinite(v[VR_M_reaction])) {
        char a[32], b[32];
        fmu_log(fi, fmi2Error, "MotorStartup '%s': input M_reaction must be finite, got %s N.m at t = %s s",
                fmu_instance_name(fi), fmu_repr(v[VR_M_reaction], a), fmu_repr(t, b));
        return fmi2Error;
    }
    publish(data, v, t);
    return fmi2OK;
}

static double next_time(const void *data, double t)
{
    const motor_startup *m = data;
    return t < 0.0 ? 0.0 : t < m->t0 ? m->t0 : INFINITY;
}

static const fmu_me ME = {
    FMU_N_STATES, FMU_N_INDICATORS, FMU_STATE_VRS, FMU_DERIVATIVE_VRS, FMU_STATE_NOMINALS, FMU_INDICATOR_VRS,
    NULL, me_eval, NULL, next_time,
};

const fmu_model FMU_MODEL = {
    FMU_IDENTIFIER, FMU_GUID, FMU_N_VARS, FMU_VARIABLES,
    sizeof(motor_startup), offsetof(motor_startup, unused),
    setup, step, NULL, inputs_set, /* no dynamic state to check */
    &ME,
};
