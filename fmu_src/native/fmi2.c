/* fmu_src/native/fmi2.c: the FMI 2.0 plumbing (co-simulation and Model Exchange) of every
 * native ballmill FMU.
 *
 * Written once for all models (fmu_model.h is the contract): the fmi2 functions, one
 * state machine that checks every call against the instance's state, logging,
 * parameter bounds, atomic steps (a refused step keeps the last good state), and FMU
 * states with their serialisation (layout, checksum and check in fmu_state.c; restored
 * states are rebuilt and checked like at initialisation). Nothing here knows physics.
 *
 * Semantics (FMI 2.0, section 4.2.4 for the allowed calls):
 *   - a call that is not allowed in the instance's state: fmi2Error, "fmi2X is not
 *     allowed in state Y", nothing changed;
 *   - fmi2DoStep with a communicationStepSize that is not positive and finite, or a
 *     currentCommunicationPoint other than the instance's time (within T_REL), or after
 *     fmi2Terminate: fmi2Error, state kept; the model steps from the instance's time to
 *     currentCommunicationPoint + communicationStepSize (as slave.Slave.do_step does);
 *   - a fixed parameter (or an output) set after initialisation, or a tunable one
 *     outside its declared bounds: fmi2Error, value kept;
 *   - every parameter outside its declared bounds, or not finite: fmi2Error at
 *     fmi2ExitInitializationMode, naming variable, value and accepted range (before the
 *     model's own checks, whose messages say what the physics needs); the messages are
 *     docs/conformance.md's (the pythonfmu flavour's);
 *   - a step whose outputs are not all finite: fmi2Discard, state kept;
 *   - fmi2Discard from a step leaves the instance in stepComplete at the last good
 *     state, so that a master may retry (with other inputs or a shorter step) or
 *     restore an FMU state.
 *
 * Model Exchange (models with an fmu_me; FMI 2.0 section 3.2.3 for the allowed calls): the
 * continuous states and their derivatives are variables (value references after the declared
 * ones); the outputs, derivatives and event indicators are evaluated lazily, once per change
 * of time, states or inputs, from the inputs as set (no reconstruction);
 *   - fmi2SetTime before the last accepted time (initialisation, the last completed
 *     integrator step or event) or not finite, fmi2SetContinuousStates with a non-finite
 *     value or outside continuous-time mode: fmi2Error naming the value, state kept;
 *   - an evaluation the model refuses (an unusable input) or that gives a non-finite
 *     output or derivative: fmi2Error naming it, the last good values kept;
 *   - fmi2NewDiscreteStates runs the model's event update (the validity latch, the next
 *     time event); with no event pending it changes nothing;
 *   - reading a state or derivative in co-simulation: fmi2Error (they are Model Exchange's).
 */
#include <math.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmu_model.h"
#include "fmu_state.h"

typedef enum {
    S_INSTANTIATED = 1,
    S_INIT = 2,
    S_STEP_COMPLETE = 4,
    S_STEP_FAILED = 8,
    S_TERMINATED = 16,
    S_ERROR = 32,
    S_FATAL = 64,
    S_EVENT = 128, /* Model Exchange: event mode */
    S_CONT = 256   /* Model Exchange: continuous-time mode */
} fmu_state;

struct fmu_instance {
    char *name;
    fmi2CallbackLogger logger;
    fmi2ComponentEnvironment env;
    int logging_on;
    fmu_state state;
    double t_start, t;   /* start time, time of the current state */
    int built;           /* setup succeeded for the current parameters */
    double *v;           /* values by value reference */
    unsigned char *data; /* the model's data */
    double *v_work;      /* scratch copies for steps */
    double call_t, call_h; /* the arguments of the fmi2DoStep being run */
    fmu_setup_kind_t setup_kind; /* why setup runs (fmu_setup_kind) */
    unsigned char *data_work;
    /* Model Exchange */
    int me;              /* instantiated as Model Exchange */
    int dirty;           /* time, states or inputs changed since the last evaluation */
    double t_accepted;   /* the last accepted time: fmi2SetTime may not go before it */
    double *z, *z_work;  /* event indicators of the last evaluation */
};

static const char *state_name(fmu_state s)
{
    switch (s) {
    case S_INSTANTIATED: return "instantiated";
    case S_INIT: return "initializationMode";
    case S_STEP_COMPLETE: return "stepComplete";
    case S_STEP_FAILED: return "stepFailed";
    case S_TERMINATED: return "terminated";
    case S_ERROR: return "error";
    case S_EVENT: return "eventMode";
    case S_CONT: return "continuousTimeMode";
    default: return "fatal";
    }
}

/* ------------------------------------------------------------------ logging */
const char *fmu_instance_name(const fmu_instance *fi) { return fi->name; }

int fmu_is_me(const fmu_instance *fi) { return fi->me; }

fmu_setup_kind_t fmu_setup_kind(const fmu_instance *fi) { return fi->setup_kind; }

double fmu_step_call(const fmu_instance *fi, char buf[160])
{
    char a[32], b[32];
    if (!buf) return fi->call_h;
    snprintf(buf, 160, "doStep(currentCommunicationPoint = %s s, communicationStepSize = %s s)",
             fmu_repr(fi->call_t, a), fmu_repr(fi->call_h, b));
    return fi->call_h;
}

void fmu_log(fmu_instance *fi, fmi2Status status, const char *fmt, ...)
{
    char msg[2048], esc[4096];
    va_list ap;
    if (!fi || !fi->logger) return;
    if (status == fmi2OK && !fi->logging_on) return;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    /* the host's logger takes the message as a printf format: '%' travels as "%%" */
    size_t j = 0;
    for (size_t i = 0; msg[i] && j + 2 < sizeof esc; i++) {
        if (msg[i] == '%') esc[j++] = '%';
        esc[j++] = msg[i];
    }
    esc[j] = '\0';
    const char *category = status == fmi2OK        ? "logAll"
                           : status == fmi2Warning ? "logStatusWarning"
                           : status == fmi2Discard ? "logStatusDiscard"
                           : status == fmi2Error   ? "logStatusError"
                                                   : "logStatusFatal";
    fi->logger(fi->env, fi->name, status, category, esc);
}

const char *fmu_repr(double x, char buf[32])
{
    if (isnan(x)) return strcpy(buf, "nan");
    if (isinf(x)) return strcpy(buf, x > 0 ? "inf" : "-inf");
    int p = 1;
    for (; p < 17; p++) { /* shortest precision that reads back as x */
        snprintf(buf, 32, "%.*e", p - 1, x);
        if (strtod(buf, NULL) == x) break;
    }
    snprintf(buf, 32, "%.*e", p - 1, x);
    int exp10 = atoi(strchr(buf, 'e') + 1);
    if (exp10 >= -4 && exp10 < 16) {
        int decimals = p - 1 - exp10;
        snprintf(buf, 32, "%.*f", decimals > 0 ? decimals : 0, x);
        if (!strchr(buf, '.')) strcat(buf, ".0");
    } else { /* Python: 1e-06, 1e+300, 1.5e+20 */
        char mant[24];
        snprintf(mant, sizeof mant, "%.*e", p - 1, x);
        *strchr(mant, 'e') = '\0';
        snprintf(buf, 32, "%.23se%c%02d", mant, exp10 < 0 ? '-' : '+', (exp10 < 0 ? -exp10 : exp10) % 1000);
    }
    return buf;
}

/* "fmi2X is not allowed in state Y": the one message for an illegal call */
static int allowed(fmu_instance *fi, const char *function, int states)
{
    if (!fi) return 0;
    if (fi->state & states) return 1;
    fmu_log(fi, fmi2Error, "%s '%s': %s is not allowed in state %s", FMU_MODEL.identifier, fi->name,
            function, state_name(fi->state));
    return 0;
}

/* the FMU's time t_c and a doStep's currentCommunicationPoint agree when they differ by at
 * most T_REL max(1 s, |t_c|) (a master's own time arithmetic; slave.T_REL) */
#define T_REL 1e-13

#define ANY_STATE (S_INSTANTIATED | S_INIT | S_STEP_COMPLETE | S_STEP_FAILED | S_TERMINATED | S_ERROR | S_EVENT | S_CONT)
#define READABLE (S_INIT | S_STEP_COMPLETE | S_STEP_FAILED | S_TERMINATED | S_ERROR | S_EVENT | S_CONT)
#define ME_RUNNING (S_EVENT | S_CONT | S_TERMINATED) /* Model Exchange after initialisation */

/* ------------------------------------------------------------------ set up */
static void start_values(fmu_instance *fi)
{
    for (int i = 0; i < FMU_MODEL.n_vars; i++) fi->v[i] = FMU_MODEL.vars[i].start;
}

/* "[lo, hi] unit" (Python's "{:g}" of the bounds, -inf/inf when there is none) */
static const char *range_text(const fmu_variable *var, char buf[96])
{
    char lo[32], hi[32];
    if (isfinite(var->min)) snprintf(lo, sizeof lo, "%g", var->min); else strcpy(lo, "-inf");
    if (isfinite(var->max)) snprintf(hi, sizeof hi, "%g", var->max); else strcpy(hi, "inf");
    int unit = *var->unit && strcmp(var->unit, "1") != 0;
    snprintf(buf, 96, "[%s, %s]%s%s", lo, hi, unit ? " " : "", unit ? var->unit : "");
    return buf;
}

/* x as Python's repr of the variable's value: "3" for Integers, "0.5" for Reals */
static const char *value_text(const fmu_variable *var, double x, char buf[32])
{
    if (var->type == FMU_INTEGER && isfinite(x)) {
        snprintf(buf, 32, "%.0f", x);
        return buf;
    }
    return fmu_repr(x, buf);
}

static const char *unit_text(const fmu_variable *var)
{
    return *var->unit && strcmp(var->unit, "1") != 0 ? var->unit : "";
}

static int in_range(const fmu_variable *var, double x)
{
    return isfinite(x) && x >= var->min && x <= var->max;
}

/* every parameter finite and within its declared bounds; fmi2Error naming the first bad one */
static fmi2Status check_parameters(fmu_instance *fi, const double *v)
{
    for (int i = 0; i < FMU_MODEL.n_vars; i++) {
        const fmu_variable *var = &FMU_MODEL.vars[i];
        if (var->causality != FMU_PARAMETER || var->type == FMU_BOOLEAN) continue;
        if (in_range(var, v[i])) continue;
        char a[32], range[96];
        const char *unit = unit_text(var);
        fmu_log(fi, fmi2Error, "%s '%s': initialisation failed: parameter %s = %s%s%s is outside its accepted "
                "range %s", FMU_MODEL.identifier, fi->name, var->name, value_text(var, v[i], a), *unit ? " " : "",
                unit, range_text(var, range));
        return fmi2Error;
    }
    return fmi2OK;
}

/* no non-finite output published with fmi2OK */
static fmi2Status check_outputs(fmu_instance *fi, const double *v, double t)
{
    for (int i = 0; i < FMU_MODEL.n_vars; i++) {
        if (FMU_MODEL.vars[i].causality != FMU_OUTPUT || isfinite(v[i])) continue;
        char a[32], b[32];
        fmu_log(fi, fmi2Discard, "%s '%s': output %s would be %s at t = %s s; refused, last good state kept",
                FMU_MODEL.identifier, fi->name, FMU_MODEL.vars[i].name, fmu_repr(v[i], a), fmu_repr(t, b));
        return fmi2Discard;
    }
    return fmi2OK;
}

/* setup on the work copies from the current values; committed on success */
static fmi2Status build(fmu_instance *fi, fmu_setup_kind_t kind)
{
    size_t nv = (size_t)FMU_MODEL.n_vars * sizeof(double);
    memcpy(fi->v_work, fi->v, nv);
    memset(fi->data_work, 0, FMU_MODEL.data_size);
    /* the declared bounds of every parameter first (docs/conformance.md), then the
     * model's own checks (its messages say what the physics needs) */
    fmi2Status s = check_parameters(fi, fi->v);
    fi->setup_kind = kind;
    if (s == fmi2OK) s = FMU_MODEL.setup(fi, fi->data_work, fi->v_work, fi->t_start);
    if (s > fmi2Warning || check_outputs(fi, fi->v_work, fi->t_start) != fmi2OK) {
        memcpy(fi->data_work, fi->data, FMU_MODEL.data_size); /* keep the copies equal */
        return fmi2Error;
    }
    memcpy(fi->v, fi->v_work, nv);
    memcpy(fi->data, fi->data_work, FMU_MODEL.data_size); /* both copies hold the configuration */
    fi->t = fi->t_start;
    fi->built = 1;
    return s;
}

/* Model Exchange: the outputs, derivatives and event indicators at the instance's time from
 * the states and inputs in v, when one of them changed since the last evaluation; on the work
 * copy, committed when the model accepts it and every output and derivative is finite */
static fmi2Status me_evaluate(fmu_instance *fi, const char *function)
{
    const fmu_me *me = FMU_MODEL.me;
    if (!fi->dirty) return fmi2OK;
    size_t nv = (size_t)FMU_MODEL.n_vars * sizeof(double);
    memcpy(fi->v_work, fi->v, nv);
    if (me->eval(fi, fi->data, fi->v_work, fi->t, fi->z_work) > fmi2Warning) {
        fmu_log(fi, fmi2Error, "%s '%s': %s: the model could not be evaluated at t = %.17g s (see the message "
                "before); last good values kept", FMU_MODEL.identifier, fi->name, function, fi->t);
        return fmi2Error;
    }
    for (int i = 0; i < FMU_MODEL.n_vars; i++) {
        const fmu_variable *var = &FMU_MODEL.vars[i];
        if ((var->causality != FMU_OUTPUT && var->causality != FMU_LOCAL) || isfinite(fi->v_work[i])) continue;
        char a[32], b[32];
        fmu_log(fi, fmi2Error, "%s '%s': %s: %s would be %s at t = %s s from the states and inputs set; refused, "
                "last good values kept", FMU_MODEL.identifier, fi->name, function, var->name,
                fmu_repr(fi->v_work[i], a), fmu_repr(fi->t, b));
        return fmi2Error;
    }
    for (int i = 0; i < me->n_indicators; i++)
        if (!isfinite(fi->z_work[i])) {
            char a[32], b[32];
            fmu_log(fi, fmi2Error, "%s '%s': %s: event indicator %d would be %s at t = %s s; refused, last good "
                    "values kept", FMU_MODEL.identifier, fi->name, function, i, fmu_repr(fi->z_work[i], a),
                    fmu_repr(fi->t, b));
            return fmi2Error;
        }
    double *tv = fi->v;
    fi->v = fi->v_work;
    fi->v_work = tv;
    double *tz = fi->z;
    fi->z = fi->z_work;
    fi->z_work = tz;
    fi->dirty = 0;
    return fmi2OK;
}

/* ------------------------------------------------------------------ life cycle */
const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }
const char *fmi2GetVersion(void) { return fmi2Version; }

static void free_instance(fmu_instance *fi)
{
    if (!fi) return;
    free(fi->name);
    free(fi->v);
    free(fi->data);
    free(fi->v_work);
    free(fi->data_work);
    free(fi->z);
    free(fi->z_work);
    free(fi);
}

fmi2Component fmi2Instantiate(fmi2String instanceName, fmi2Type fmuType, fmi2String fmuGUID,
                              fmi2String fmuResourceLocation, const fmi2CallbackFunctions *functions,
                              fmi2Boolean visible, fmi2Boolean loggingOn)
{
    (void)fmuResourceLocation;
    (void)visible;
    fmu_instance tmp = {0};
    tmp.name = (char *)(instanceName ? instanceName : "?");
    tmp.logger = functions ? functions->logger : NULL;
    tmp.env = functions ? functions->componentEnvironment : NULL;
    if (!instanceName || !*instanceName) {
        fmu_log(&tmp, fmi2Error, "%s: fmi2Instantiate: the instance name must not be empty", FMU_MODEL.identifier);
        return NULL;
    }
    if (fmuType != fmi2CoSimulation && !(fmuType == fmi2ModelExchange && FMU_MODEL.me)) {
        fmu_log(&tmp, fmi2Error, "%s '%s': fmi2Instantiate: fmuType = %d refused: this FMU supports %s",
                FMU_MODEL.identifier, instanceName, (int)fmuType,
                FMU_MODEL.me ? "fmi2ModelExchange (0) and fmi2CoSimulation (1)" : "only fmi2CoSimulation (1)");
        return NULL;
    }
    if (!fmuGUID || strcmp(fmuGUID, FMU_MODEL.guid) != 0) {
        fmu_log(&tmp, fmi2Error, "%s '%s': fmi2Instantiate: GUID %s does not match this binary's %s",
                FMU_MODEL.identifier, instanceName, fmuGUID ? fmuGUID : "(null)", FMU_MODEL.guid);
        return NULL;
    }
    fmu_instance *fi = calloc(1, sizeof *fi);
    size_t nv = (size_t)FMU_MODEL.n_vars;
    if (fi) {
        fi->name = malloc(strlen(instanceName) + 1);
        fi->v = calloc(nv, sizeof(double));
        fi->v_work = calloc(nv, sizeof(double));
        fi->data = calloc(1, FMU_MODEL.data_size);
        fi->data_work = calloc(1, FMU_MODEL.data_size);
        size_t nz = FMU_MODEL.me && FMU_MODEL.me->n_indicators > 0 ? (size_t)FMU_MODEL.me->n_indicators : 1;
        fi->z = calloc(nz, sizeof(double));
        fi->z_work = calloc(nz, sizeof(double));
    }
    if (!fi || !fi->name || !fi->v || !fi->v_work || !fi->data || !fi->data_work || !fi->z || !fi->z_work) {
        free_instance(fi);
        fmu_log(&tmp, fmi2Fatal, "%s '%s': fmi2Instantiate: out of memory", FMU_MODEL.identifier, instanceName);
        return NULL;
    }
    strcpy(fi->name, instanceName);
    fi->logger = tmp.logger;
    fi->env = tmp.env;
    fi->logging_on = loggingOn ? 1 : 0;
    fi->state = S_INSTANTIATED;
    fi->me = fmuType == fmi2ModelExchange;
    fi->dirty = 1;
    start_values(fi);
    return fi;
}

void fmi2FreeInstance(fmi2Component c)
{
    free_instance((fmu_instance *)c);
}

fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean loggingOn, size_t nCategories,
                               const fmi2String categories[])
{
    fmu_instance *fi = c;
    (void)nCategories;
    (void)categories;
    if (!allowed(fi, "fmi2SetDebugLogging", ANY_STATE)) return fmi2Error;
    fi->logging_on = loggingOn ? 1 : 0;
    return fmi2OK;
}

fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean toleranceDefined, fmi2Real tolerance,
                               fmi2Real startTime, fmi2Boolean stopTimeDefined, fmi2Real stopTime)
{
    fmu_instance *fi = c;
    char a[32];
    (void)toleranceDefined;
    (void)tolerance;
    (void)stopTimeDefined;
    (void)stopTime;
    if (!allowed(fi, "fmi2SetupExperiment", S_INSTANTIATED)) return fmi2Error;
    if (!isfinite(startTime)) {
        fmu_log(fi, fmi2Error, "%s '%s': fmi2SetupExperiment: startTime = %s s must be finite",
                FMU_MODEL.identifier, fi->name, fmu_repr(startTime, a));
        return fmi2Error;
    }
    fi->t_start = fi->t = startTime;
    return fmi2OK;
}

fmi2Status fmi2EnterInitializationMode(fmi2Component c)
{
    fmu_instance *fi = c;
    if (!allowed(fi, "fmi2EnterInitializationMode", S_INSTANTIATED)) return fmi2Error;
    fi->state = S_INIT;
    fi->built = 0;
    return fmi2OK;
}

fmi2Status fmi2ExitInitializationMode(fmi2Component c)
{
    fmu_instance *fi = c;
    if (!allowed(fi, "fmi2ExitInitializationMode", S_INIT)) return fmi2Error;
    fmi2Status s = build(fi, FMU_SETUP_START);
    if (s > fmi2Warning) return fmi2Error; /* stays in initialisation mode: fix the parameters and retry */
    if (fi->me) {
        /* Model Exchange: the model's start state (after its check of what it supports) */
        size_t nv = (size_t)FMU_MODEL.n_vars * sizeof(double);
        memcpy(fi->v_work, fi->v, nv);
        fmi2Status m = FMU_MODEL.me->start(fi, fi->data, fi->v_work, fi->t);
        if (m > fmi2Warning) return fmi2Error;
        memcpy(fi->v, fi->v_work, nv);
        fi->dirty = 1;
        if (me_evaluate(fi, "fmi2ExitInitializationMode") != fmi2OK) return fmi2Error;
        fi->t_accepted = fi->t;
        fi->state = S_EVENT; /* FMI 2.0: initialisation ends in event mode */
        return m > s ? m : s;
    }
    fi->state = S_STEP_COMPLETE;
    return s;
}

fmi2Status fmi2Terminate(fmi2Component c)
{
    fmu_instance *fi = c;
    if (!allowed(fi, "fmi2Terminate", S_STEP_COMPLETE | S_STEP_FAILED | S_EVENT | S_CONT)) return fmi2Error;
    fi->state = S_TERMINATED;
    return fmi2OK;
}

fmi2Status fmi2Reset(fmi2Component c)
{
    fmu_instance *fi = c;
    if (!allowed(fi, "fmi2Reset", ANY_STATE)) return fmi2Error;
    fi->state = S_INSTANTIATED;
    fi->built = 0;
    fi->t_start = fi->t = fi->t_accepted = 0.0;
    fi->dirty = 1;
    start_values(fi);
    memset(fi->data, 0, FMU_MODEL.data_size);
    memset(fi->data_work, 0, FMU_MODEL.data_size);
    return fmi2OK;
}

/* ------------------------------------------------------------------ get / set */
static const char *type_name(fmu_type t)
{
    return t == FMU_REAL ? "Real" : t == FMU_INTEGER ? "Integer" : "Boolean";
}

static fmi2Status check_vr(fmu_instance *fi, const char *function, fmi2ValueReference vr, fmu_type type)
{
    if (vr >= (fmi2ValueReference)FMU_MODEL.n_vars) {
        fmu_log(fi, fmi2Error, "%s '%s': %s: no variable has value reference %u", FMU_MODEL.identifier,
                fi->name, function, (unsigned)vr);
        return fmi2Error;
    }
    if (FMU_MODEL.vars[vr].type != type) {
        fmu_log(fi, fmi2Error, "%s '%s': %s: value reference %u is %s, a %s, not a %s", FMU_MODEL.identifier,
                fi->name, function, (unsigned)vr, FMU_MODEL.vars[vr].name,
                type_name(FMU_MODEL.vars[vr].type), type_name(type));
        return fmi2Error;
    }
    return fmi2OK;
}

static fmi2Status get_values(fmu_instance *fi, const char *function, const fmi2ValueReference vr[],
                             size_t nvr, fmu_type type, double *out)
{
    if (!allowed(fi, function, READABLE)) return fmi2Error;
    if (nvr && (!vr || !out)) return fmi2Error;
    for (size_t i = 0; i < nvr; i++)
        if (check_vr(fi, function, vr[i], type) != fmi2OK) return fmi2Error;
    for (size_t i = 0; i < nvr; i++) {
        const fmu_variable *var = &FMU_MODEL.vars[vr[i]];
        if (var->causality != FMU_LOCAL || (fi->me && (fi->state & ME_RUNNING))) continue;
        fmu_log(fi, fmi2Error, "%s '%s': %s: %s is a Model Exchange variable (a continuous state or its "
                "derivative): %s", FMU_MODEL.identifier, fi->name, function, var->name,
                fi->me ? "it is known from fmi2ExitInitializationMode on"
                       : "co-simulation does not compute it; read the outputs");
        return fmi2Error;
    }
    if (fi->state == S_INIT && build(fi, FMU_SETUP_PREVIEW) > fmi2Warning) /* outputs consistent with the inputs set so far */
        return fmi2Error;
    if (fi->me && (fi->state & ME_RUNNING) && me_evaluate(fi, function) != fmi2OK) return fmi2Error;
    for (size_t i = 0; i < nvr; i++) out[i] = fi->v[vr[i]];
    return fmi2OK;
}

/* may vr be set now? A fixed parameter only before the end of initialisation, an input
 * from instantiation on, an output never. */
static fmi2Status settable(fmu_instance *fi, const char *function, fmi2ValueReference vr, double x)
{
    const fmu_variable *var = &FMU_MODEL.vars[vr];
    const char *unit = unit_text(var), *sep = *unit ? " " : "";
    char a[32], b[32], range[96], why[256];
    int initialised = !(fi->state & (S_INSTANTIATED | S_INIT));
    why[0] = '\0';
    if (var->causality == FMU_OUTPUT)
        snprintf(why, sizeof why, "%s is an output and cannot be set (got %s = %s%s%s)", var->name, var->name,
                 value_text(var, x, a), sep, unit);
    else if (var->causality == FMU_LOCAL)
        snprintf(why, sizeof why, "%s is a Model Exchange state or derivative: set the states with "
                 "fmi2SetContinuousStates (got %s = %s%s%s)", var->name, var->name, value_text(var, x, a), sep, unit);
    else if (var->causality == FMU_PARAMETER && !var->tunable && initialised)
        snprintf(why, sizeof why, "parameter %s is fixed: it can be set only before fmi2ExitInitializationMode "
                 "(fmi2Reset, then set it); %s = %s%s%s refused, %s keeps %s%s%s", var->name, var->name,
                 value_text(var, x, a), sep, unit, var->name, value_text(var, fi->v[vr], b), sep, unit);
    else if (var->causality == FMU_PARAMETER && var->tunable && initialised && !in_range(var, x))
        snprintf(why, sizeof why, "tunable parameter %s = %s%s%s refused: accepted range %s; %s keeps %s%s%s",
                 var->name, value_text(var, x, a), sep, unit, range_text(var, range), var->name,
                 value_text(var, fi->v[vr], b), sep, unit);
    if (!why[0]) return fmi2OK;
    fmu_log(fi, fmi2Error, "%s '%s': %s: %s cannot be set in state %s: %s", FMU_MODEL.identifier, fi->name,
            function, var->name, state_name(fi->state), why);
    return fmi2Error;
}

static fmi2Status set_values(fmu_instance *fi, const char *function, const fmi2ValueReference vr[],
                             size_t nvr, fmu_type type, const double *in)
{
    if (!allowed(fi, function, S_INSTANTIATED | S_INIT | S_STEP_COMPLETE | S_EVENT | S_CONT)) return fmi2Error;
    if (nvr && (!vr || !in)) return fmi2Error;
    for (size_t i = 0; i < nvr; i++) /* all or nothing */
        if (check_vr(fi, function, vr[i], type) != fmi2OK || settable(fi, function, vr[i], in[i]) != fmi2OK)
            return fmi2Error;
    int input = 0;
    for (size_t i = 0; i < nvr; i++) {
        fi->v[vr[i]] = in[i];
        input |= FMU_MODEL.vars[vr[i]].causality == FMU_INPUT;
    }
    if (fi->me) { /* Model Exchange: the next read evaluates at the inputs set */
        fi->dirty = 1;
        return fmi2OK;
    }
    /* direct feedthrough: outputs that depend on the inputs follow them between steps (in
     * initialisation mode every read rebuilds them anyway) */
    if (input && fi->state == S_STEP_COMPLETE && FMU_MODEL.inputs_set)
        return FMU_MODEL.inputs_set(fi, fi->data, fi->v, fi->t);
    return fmi2OK;
}

fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Real value[])
{
    return get_values(c, "fmi2GetReal", vr, nvr, FMU_REAL, value);
}

#define CHUNK 64
fmi2Status fmi2GetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Integer value[])
{
    double buf[CHUNK];
    for (size_t k = 0; k < nvr || k == 0; k += CHUNK) {
        size_t n = nvr - k < CHUNK ? nvr - k : CHUNK;
        fmi2Status s = get_values(c, "fmi2GetInteger", vr ? vr + k : NULL, n, FMU_INTEGER, buf);
        if (s != fmi2OK) return s;
        for (size_t i = 0; i < n; i++) value[k + i] = (fmi2Integer)buf[i];
        if (nvr == 0) break;
    }
    return fmi2OK;
}

fmi2Status fmi2GetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Boolean value[])
{
    double buf[CHUNK];
    for (size_t k = 0; k < nvr || k == 0; k += CHUNK) {
        size_t n = nvr - k < CHUNK ? nvr - k : CHUNK;
        fmi2Status s = get_values(c, "fmi2GetBoolean", vr ? vr + k : NULL, n, FMU_BOOLEAN, buf);
        if (s != fmi2OK) return s;
        for (size_t i = 0; i < n; i++) value[k + i] = buf[i] != 0.0 ? fmi2True : fmi2False;
        if (nvr == 0) break;
    }
    return fmi2OK;
}

fmi2Status fmi2GetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2String value[])
{
    fmu_instance *fi = c;
    (void)vr;
    (void)value;
    if (!allowed(fi, "fmi2GetString", READABLE)) return fmi2Error;
    if (nvr == 0) return fmi2OK;
    fmu_log(fi, fmi2Error, "%s '%s': fmi2GetString: this FMU has no String variables", FMU_MODEL.identifier,
            fi->name);
    return fmi2Error;
}

fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Real value[])
{
    return set_values(c, "fmi2SetReal", vr, nvr, FMU_REAL, value);
}

fmi2Status fmi2SetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Integer value[])
{
    fmu_instance *fi = c;
    double *buf = malloc((nvr ? nvr : 1) * sizeof(double));
    if (!buf) return fmi2Error;
    for (size_t i = 0; i < nvr; i++) buf[i] = (double)value[i];
    fmi2Status s = set_values(fi, "fmi2SetInteger", vr, nvr, FMU_INTEGER, buf);
    free(buf);
    return s;
}

fmi2Status fmi2SetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Boolean value[])
{
    fmu_instance *fi = c;
    double *buf = malloc((nvr ? nvr : 1) * sizeof(double));
    if (!buf) return fmi2Error;
    for (size_t i = 0; i < nvr; i++) buf[i] = value[i] ? 1.0 : 0.0;
    fmi2Status s = set_values(fi, "fmi2SetBoolean", vr, nvr, FMU_BOOLEAN, buf);
    free(buf);
    return s;
}

fmi2Status fmi2SetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2String value[])
{
    fmu_instance *fi = c;
    (void)vr;
    (void)value;
    if (!allowed(fi, "fmi2SetString", S_INSTANTIATED | S_INIT | S_STEP_COMPLETE)) return fmi2Error;
    if (nvr == 0) return fmi2OK;
    fmu_log(fi, fmi2Error, "%s '%s': fmi2SetString: this FMU has no String variables", FMU_MODEL.identifier,
            fi->name);
    return fmi2Error;
}

/* ------------------------------------------------------------------ stepping */
fmi2Status fmi2DoStep(fmi2Component c, fmi2Real currentCommunicationPoint, fmi2Real communicationStepSize,
                      fmi2Boolean noSetFMUStatePriorToCurrentPoint)
{
    fmu_instance *fi = c;
    char a[32], b[32];
    double t = currentCommunicationPoint, h = communicationStepSize;
    (void)noSetFMUStatePriorToCurrentPoint;
    if (fi && fi->state == S_TERMINATED) {
        fmu_log(fi, fmi2Error, "%s '%s': fmi2DoStep(currentCommunicationPoint = %s s, communicationStepSize = "
                "%s s) after fmi2Terminate refused: fmi2DoStep is not allowed in state terminated",
                FMU_MODEL.identifier, fi->name, fmu_repr(t, a), fmu_repr(h, b));
        return fmi2Error;
    }
    if (!allowed(fi, "fmi2DoStep", S_STEP_COMPLETE)) return fmi2Error;
    if (!(isfinite(h) && h > 0.0)) {
        fmu_log(fi, fmi2Error, "%s '%s': fmi2DoStep: communicationStepSize = %s s refused: it must be positive "
                "and finite; state unchanged", FMU_MODEL.identifier, fi->name, fmu_repr(h, a));
        return fmi2Error;
    }
    if (!(fabs(t - fi->t) <= T_REL * fmax(1.0, fabs(fi->t)))) {
        fmu_log(fi, fmi2Error, "%s '%s': fmi2DoStep: currentCommunicationPoint = %s s refused: "
                "currentCommunicationPoint must equal the FMU's time t = %s s (steps are contiguous; restore an "
                "FMU state to go back); state unchanged",
                FMU_MODEL.identifier, fi->name, fmu_repr(t, a), fmu_repr(fi->t, b));
        return fmi2Error;
    }
    double t_end = t + h;
    if (!(t_end > fi->t)) {
        fmu_log(fi, fmi2Error, "%s '%s': fmi2DoStep: the step ends at %s s, not after the FMU's time t = %s s; "
                "state unchanged", FMU_MODEL.identifier, fi->name, fmu_repr(t_end, a), fmu_repr(fi->t, b));
        return fmi2Error;
    }
    /* the step runs on the work copies; the configuration part of the data is the same in
     * both (build and fmi2SetFMUstate write both), so only the dynamic part is copied */
    size_t nv = (size_t)FMU_MODEL.n_vars * sizeof(double);
    memcpy(fi->v_work, fi->v, nv);
    memcpy(fi->data_work + FMU_MODEL.dyn_offset, fi->data + FMU_MODEL.dyn_offset,
           FMU_MODEL.data_size - FMU_MODEL.dyn_offset);
    fi->call_t = t;
    fi->call_h = h;
    /* from the FMU's time to the master's end of the step (slave.Slave.do_step) */
    fmi2Status s = FMU_MODEL.step(fi, fi->data_work, fi->v_work, fi->t, t_end);
    if (s <= fmi2Warning && check_outputs(fi, fi->v_work, t_end) != fmi2OK) s = fmi2Discard;
    if (s > fmi2Warning) return s == fmi2Discard ? fmi2Discard : fmi2Error; /* the last good state stays */
    double *tv = fi->v;
    fi->v = fi->v_work;
    fi->v_work = tv;
    unsigned char *td = fi->data;
    fi->data = fi->data_work;
    fi->data_work = td;
    fi->t = t_end;
    return s;
}

fmi2Status fmi2CancelStep(fmi2Component c)
{
    fmu_instance *fi = c;
    if (fi) fmu_log(fi, fmi2Error, "%s '%s': fmi2CancelStep is not allowed in state %s (steps are synchronous)",
                    FMU_MODEL.identifier, fi->name, state_name(fi->state));
    return fmi2Error;
}

fmi2Status fmi2SetRealInputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                       const fmi2Integer order[], const fmi2Real value[])
{
    fmu_instance *fi = c;
    (void)vr;
    (void)nvr;
    (void)order;
    (void)value;
    if (fi) fmu_log(fi, fmi2Error, "%s '%s': fmi2SetRealInputDerivatives: not supported "
                    "(canInterpolateInputs = false)", FMU_MODEL.identifier, fi->name);
    return fmi2Error;
}

fmi2Status fmi2GetRealOutputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                        const fmi2Integer order[], fmi2Real value[])
{
    fmu_instance *fi = c;
    (void)vr;
    (void)nvr;
    (void)order;
    (void)value;
    if (fi) fmu_log(fi, fmi2Error, "%s '%s': fmi2GetRealOutputDerivatives: not supported "
                    "(maxOutputDerivativeOrder = 0)", FMU_MODEL.identifier, fi->name);
    return fmi2Error;
}

fmi2Status fmi2GetDirectionalDerivative(fmi2Component c, const fmi2ValueReference vUnknown_ref[], size_t nUnknown,
                                        const fmi2ValueReference vKnown_ref[], size_t nKnown,
                                        const fmi2Real dvKnown[], fmi2Real dvUnknown[])
{
    fmu_instance *fi = c;
    (void)vUnknown_ref;
    (void)nUnknown;
    (void)vKnown_ref;
    (void)nKnown;
    (void)dvKnown;
    (void)dvUnknown;
    if (fi) fmu_log(fi, fmi2Error, "%s '%s': fmi2GetDirectionalDerivative: not supported "
                    "(providesDirectionalDerivative = false)", FMU_MODEL.identifier, fi->name);
    return fmi2Error;
}

fmi2Status fmi2GetStatus(fmi2Component c, const fmi2StatusKind s, fmi2Status *value)
{
    fmu_instance *fi = c;
    if (!allowed(fi, "fmi2GetStatus", S_STEP_COMPLETE | S_STEP_FAILED | S_TERMINATED)) return fmi2Error;
    if (s != fmi2DoStepStatus || !value) return fmi2Discard;
    *value = fmi2OK; /* steps are synchronous: never pending */
    return fmi2OK;
}

fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind s, fmi2Real *value)
{
    fmu_instance *fi = c;
    if (!allowed(fi, "fmi2GetRealStatus", S_STEP_COMPLETE | S_STEP_FAILED | S_TERMINATED)) return fmi2Error;
    if (s != fmi2LastSuccessfulTime || !value) return fmi2Discard;
    *value = fi->t;
    return fmi2OK;
}

fmi2Status fmi2GetIntegerStatus(fmi2Component c, const fmi2StatusKind s, fmi2Integer *value)
{
    (void)c;
    (void)s;
    (void)value;
    return fmi2Discard;
}

fmi2Status fmi2GetBooleanStatus(fmi2Component c, const fmi2StatusKind s, fmi2Boolean *value)
{
    fmu_instance *fi = c;
    if (!allowed(fi, "fmi2GetBooleanStatus", S_STEP_COMPLETE | S_STEP_FAILED | S_TERMINATED)) return fmi2Error;
    if (s != fmi2Terminated || !value) return fmi2Discard;
    *value = fmi2False;
    return fmi2OK;
}

fmi2Status fmi2GetStringStatus(fmi2Component c, const fmi2StatusKind s, fmi2String *value)
{
    (void)c;
    (void)s;
    (void)value;
    return fmi2Discard;
}

/* ------------------------------------------------------------------ FMU states */
/* The layout, checksum and check of a state are fmu_state.c's; here: which instance states
 * a state may carry, and what the fmi2 calls do with one. */
#define FMI_VERSION 2u
/* the instance states an FMU state may carry: those of the instance's interface */
#define STATE_PHASES (S_INSTANTIATED | S_INIT | S_TERMINATED | (fi->me ? S_EVENT | S_CONT : S_STEP_COMPLETE | S_STEP_FAILED))

fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate *state)
{
    fmu_instance *fi = c;
    if (!allowed(fi, "fmi2GetFMUstate", ANY_STATE)) return fmi2Error;
    if (!state) return fmi2Error;
    unsigned char *b = *state ? *state : malloc(fmu_state_size()); /* a given state is overwritten */
    if (!b) {
        fmu_log(fi, fmi2Error, "%s '%s': fmi2GetFMUstate: out of memory", FMU_MODEL.identifier, fi->name);
        return fmi2Error;
    }
    fmu_state_write(b, FMI_VERSION, (int32_t)fi->state, fi->built, fi->t_start, fi->t, fi->v, fi->data);
    *state = b;
    return fmi2OK;
}

fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate state)
{
    fmu_instance *fi = c;
    const unsigned char *b = state;
    if (!allowed(fi, "fmi2SetFMUstate", ANY_STATE)) return fmi2Error;
    char why[FMU_STATE_WHY];
    if (fmu_state_check(b, fmu_state_size(), FMI_VERSION, STATE_PHASES, 0, why)) {
        fmu_log(fi, fmi2Error, "%s '%s': fmi2SetFMUstate: state refused, instance unchanged: %s",
                FMU_MODEL.identifier, fi->name, why);
        return fmi2Error;
    }
    fmu_state_header h;
    fmu_state_header_of(b, &h);
    const double *v = fmu_state_values(b);
    const unsigned char *data = fmu_state_data(b);
    size_t nv = (size_t)FMU_MODEL.n_vars * sizeof(double);
    if (h.built) {
        /* the configuration is rebuilt from the state's parameters (checked like at
         * initialisation), then the dynamic state is taken over and checked */
        memcpy(fi->v_work, v, nv);
        memset(fi->data_work, 0, FMU_MODEL.data_size);
        if (check_parameters(fi, v) != fmi2OK) goto refused;
        fi->setup_kind = FMU_SETUP_RESTORE;
        if (FMU_MODEL.setup(fi, fi->data_work, fi->v_work, h.t_start) > fmi2Warning) goto refused;
        memcpy(fi->v_work, v, nv); /* outputs and inputs as they were saved */
        memcpy(fi->data_work + FMU_MODEL.dyn_offset, data + FMU_MODEL.dyn_offset,
               FMU_MODEL.data_size - FMU_MODEL.dyn_offset);
        if (FMU_MODEL.check && FMU_MODEL.check(fi, fi->data_work, fi->v_work) > fmi2Warning) goto refused;
        memcpy(fi->data, fi->data_work, FMU_MODEL.data_size); /* both copies hold the configuration */
    } else {
        memset(fi->data, 0, FMU_MODEL.data_size);
        memset(fi->data_work, 0, FMU_MODEL.data_size);
        memcpy(fi->v_work, v, nv);
    }
    memcpy(fi->v, fi->v_work, nv);
    fi->state = (fmu_state)h.phase;
    fi->built = h.built;
    fi->t_start = h.t_start;
    fi->t = fi->t_accepted = h.t;
    fi->dirty = 1;
    return fmi2OK;
refused:
    memcpy(fi->data_work, fi->data, FMU_MODEL.data_size); /* keep the copies equal */
    fmu_log(fi, fmi2Error, "%s '%s': fmi2SetFMUstate: state refused (see the message before), instance unchanged",
            FMU_MODEL.identifier, fi->name);
    return fmi2Error;
}

fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate *state)
{
    fmu_instance *fi = c;
    if (!allowed(fi, "fmi2FreeFMUstate", ANY_STATE)) return fmi2Error;
    if (state) {
        free(*state);
        *state = NULL;
    }
    return fmi2OK;
}

fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate state, size_t *size)
{
    fmu_instance *fi = c;
    (void)state;
    if (!allowed(fi, "fmi2SerializedFMUstateSize", ANY_STATE) || !size) return fmi2Error;
    *size = fmu_state_size();
    return fmi2OK;
}

fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate state, fmi2Byte serializedState[], size_t size)
{
    fmu_instance *fi = c;
    if (!allowed(fi, "fmi2SerializeFMUstate", ANY_STATE)) return fmi2Error;
    char why[FMU_STATE_WHY];
    if (!fmu_state_check(state, fmu_state_size(), FMI_VERSION, STATE_PHASES, 0, why)) {
        if (!serializedState) snprintf(why, sizeof why, "no buffer given");
        else if (size < fmu_state_size())
            snprintf(why, sizeof why, "the buffer has %zu bytes, fewer than fmi2SerializedFMUstateSize = %zu", size,
                     fmu_state_size());
    }
    if (*why) {
        fmu_log(fi, fmi2Error, "%s '%s': fmi2SerializeFMUstate: %s", FMU_MODEL.identifier, fi->name, why);
        return fmi2Error;
    }
    memcpy(serializedState, state, fmu_state_size());
    fmu_state_seal((unsigned char *)serializedState); /* the checksum: only serialised states carry it */
    return fmi2OK;
}

fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte serializedState[], size_t size,
                                   fmi2FMUstate *state)
{
    fmu_instance *fi = c;
    if (!allowed(fi, "fmi2DeSerializeFMUstate", ANY_STATE) || !state) return fmi2Error;
    char why[FMU_STATE_WHY];
    if (fmu_state_check((const unsigned char *)serializedState, size, FMI_VERSION, STATE_PHASES, 1, why)) {
        fmu_log(fi, fmi2Error, "%s '%s': fmi2DeSerializeFMUstate: state refused: %s", FMU_MODEL.identifier,
                fi->name, why);
        return fmi2Error;
    }
    unsigned char *b = malloc(size);
    if (!b) return fmi2Error;
    memcpy(b, serializedState, size);
    *state = b;
    return fmi2OK;
}

/* ------------------------------------------------------------------ Model Exchange */
static int me_instance(fmu_instance *fi, const char *function)
{
    if (!fi) return 0;
    if (fi->me) return 1;
    fmu_log(fi, fmi2Error, "%s '%s': %s is a Model Exchange function; this instance is co-simulation",
            FMU_MODEL.identifier, fi->name, function);
    return 0;
}

/* nx must be the model's number of states (nz its number of event indicators) */
static int count_is(fmu_instance *fi, const char *function, const char *what, size_t n, int expected)
{
    if (n == (size_t)expected) return 1;
    fmu_log(fi, fmi2Error, "%s '%s': %s: %s = %zu refused: this FMU has %d", FMU_MODEL.identifier, fi->name,
            function, what, n, expected);
    return 0;
}

fmi2Status fmi2EnterEventMode(fmi2Component c)
{
    fmu_instance *fi = c;
    if (!me_instance(fi, "fmi2EnterEventMode") || !allowed(fi, "fmi2EnterEventMode", S_CONT)) return fmi2Error;
    fi->state = S_EVENT;
    return fmi2OK;
}

fmi2Status fmi2NewDiscreteStates(fmi2Component c, fmi2EventInfo *info)
{
    fmu_instance *fi = c;
    if (!me_instance(fi, "fmi2NewDiscreteStates") || !allowed(fi, "fmi2NewDiscreteStates", S_EVENT) || !info)
        return fmi2Error;
    if (me_evaluate(fi, "fmi2NewDiscreteStates") != fmi2OK) return fmi2Error;
    size_t nv = (size_t)FMU_MODEL.n_vars * sizeof(double);
    memcpy(fi->v_work, fi->v, nv);
    fmu_event ev = {0, 0, 0, 0.0};
    fmi2Status s = FMU_MODEL.me->event(fi, fi->data, fi->v_work, fi->t, &ev);
    if (s > fmi2Warning) return fmi2Error;
    double *tv = fi->v;
    fi->v = fi->v_work;
    fi->v_work = tv;
    if (ev.states_changed) fi->dirty = 1;
    fi->t_accepted = fi->t;
    info->newDiscreteStatesNeeded = fmi2False; /* one update settles every event of these models */
    info->terminateSimulation = ev.terminate ? fmi2True : fmi2False;
    info->nominalsOfContinuousStatesChanged = fmi2False;
    info->valuesOfContinuousStatesChanged = ev.states_changed ? fmi2True : fmi2False;
    info->nextEventTimeDefined = ev.next_time_defined ? fmi2True : fmi2False;
    info->nextEventTime = ev.next_time_defined ? ev.next_time : 0.0;
    return s;
}

fmi2Status fmi2EnterContinuousTimeMode(fmi2Component c)
{
    fmu_instance *fi = c;
    if (!me_instance(fi, "fmi2EnterContinuousTimeMode") || !allowed(fi, "fmi2EnterContinuousTimeMode", S_EVENT))
        return fmi2Error;
    fi->state = S_CONT;
    return fmi2OK;
}

fmi2Status fmi2CompletedIntegratorStep(fmi2Component c, fmi2Boolean noSetFMUStatePriorToCurrentPoint,
                                       fmi2Boolean *enterEventMode, fmi2Boolean *terminateSimulation)
{
    fmu_instance *fi = c;
    (void)noSetFMUStatePriorToCurrentPoint;
    if (!me_instance(fi, "fmi2CompletedIntegratorStep") || !allowed(fi, "fmi2CompletedIntegratorStep", S_CONT))
        return fmi2Error;
    fi->t_accepted = fi->t;
    if (enterEventMode) *enterEventMode = fmi2False; /* every event is a state or time event */
    if (terminateSimulation) *terminateSimulation = fmi2False;
    return fmi2OK;
}

fmi2Status fmi2SetTime(fmi2Component c, fmi2Real time)
{
    fmu_instance *fi = c;
    char a[32], b[32], d[32];
    if (!me_instance(fi, "fmi2SetTime") || !allowed(fi, "fmi2SetTime", S_EVENT | S_CONT)) return fmi2Error;
    if (!isfinite(time)) {
        fmu_log(fi, fmi2Error, "%s '%s': fmi2SetTime: time = %s s refused: it must be finite; time stays %s s",
                FMU_MODEL.identifier, fi->name, fmu_repr(time, a), fmu_repr(fi->t, b));
        return fmi2Error;
    }
    if (time < fi->t_accepted - T_REL * fmax(1.0, fabs(fi->t_accepted))) {
        fmu_log(fi, fmi2Error, "%s '%s': fmi2SetTime: time = %s s refused: it is before the last accepted time "
                "%s s (the end of initialisation, the last completed integrator step or event); time stays %s s "
                "(restore an FMU state to go back)", FMU_MODEL.identifier, fi->name, fmu_repr(time, a),
                fmu_repr(fi->t_accepted, b), fmu_repr(fi->t, d));
        return fmi2Error;
    }
    if (time != fi->t) fi->dirty = 1;
    fi->t = time;
    return fmi2OK;
}

fmi2Status fmi2SetContinuousStates(fmi2Component c, const fmi2Real x[], size_t nx)
{
    fmu_instance *fi = c;
    const fmu_me *me = FMU_MODEL.me;
    if (!me_instance(fi, "fmi2SetContinuousStates")) return fmi2Error;
    if (fi->state == S_EVENT) {
        fmu_log(fi, fmi2Error, "%s '%s': fmi2SetContinuousStates is not allowed in state eventMode: the states "
                "are set in continuousTimeMode (in event mode only the FMU's event update changes them); "
                "states unchanged", FMU_MODEL.identifier, fi->name);
        return fmi2Error;
    }
    if (!allowed(fi, "fmi2SetContinuousStates", S_CONT)) return fmi2Error;
    if (!count_is(fi, "fmi2SetContinuousStates", "nx", nx, me->n_states)) return fmi2Error;
    if (nx && !x) return fmi2Error;
    for (size_t i = 0; i < nx; i++)
        if (!isfinite(x[i])) {
            char a[32], b[32], d[32];
            const fmu_variable *var = &FMU_MODEL.vars[me->state_vr[i]];
            fmu_log(fi, fmi2Error, "%s '%s': fmi2SetContinuousStates: %s = %s%s%s refused at t = %s s: every "
                    "continuous state must be finite; states unchanged (%s keeps %s)", FMU_MODEL.identifier,
                    fi->name, var->name, fmu_repr(x[i], a), *unit_text(var) ? " " : "", unit_text(var),
                    fmu_repr(fi->t, b), var->name, fmu_repr(fi->v[me->state_vr[i]], d));
            return fmi2Error;
        }
    for (size_t i = 0; i < nx; i++) {
        if (fi->v[me->state_vr[i]] != x[i]) fi->dirty = 1;
        fi->v[me->state_vr[i]] = x[i];
    }
    return fmi2OK;
}

fmi2Status fmi2GetContinuousStates(fmi2Component c, fmi2Real x[], size_t nx)
{
    fmu_instance *fi = c;
    const fmu_me *me = FMU_MODEL.me;
    if (!me_instance(fi, "fmi2GetContinuousStates") || !allowed(fi, "fmi2GetContinuousStates", ME_RUNNING))
        return fmi2Error;
    if (!count_is(fi, "fmi2GetContinuousStates", "nx", nx, me->n_states) || (nx && !x)) return fmi2Error;
    for (size_t i = 0; i < nx; i++) x[i] = fi->v[me->state_vr[i]];
    return fmi2OK;
}

fmi2Status fmi2GetDerivatives(fmi2Component c, fmi2Real derivatives[], size_t nx)
{
    fmu_instance *fi = c;
    const fmu_me *me = FMU_MODEL.me;
    if (!me_instance(fi, "fmi2GetDerivatives") || !allowed(fi, "fmi2GetDerivatives", ME_RUNNING)) return fmi2Error;
    if (!count_is(fi, "fmi2GetDerivatives", "nx", nx, me->n_states) || (nx && !derivatives)) return fmi2Error;
    if (me_evaluate(fi, "fmi2GetDerivatives") != fmi2OK) return fmi2Error;
    for (size_t i = 0; i < nx; i++) derivatives[i] = fi->v[me->der_vr[i]];
    return fmi2OK;
}

fmi2Status fmi2GetEventIndicators(fmi2Component c, fmi2Real eventIndicators[], size_t ni)
{
    fmu_instance *fi = c;
    const fmu_me *me = FMU_MODEL.me;
    if (!me_instance(fi, "fmi2GetEventIndicators") || !allowed(fi, "fmi2GetEventIndicators", ME_RUNNING))
        return fmi2Error;
    if (!count_is(fi, "fmi2GetEventIndicators", "ni", ni, me->n_indicators) || (ni && !eventIndicators))
        return fmi2Error;
    if (me_evaluate(fi, "fmi2GetEventIndicators") != fmi2OK) return fmi2Error;
    for (size_t i = 0; i < ni; i++) eventIndicators[i] = fi->z[i];
    return fmi2OK;
}

fmi2Status fmi2GetNominalsOfContinuousStates(fmi2Component c, fmi2Real x_nominal[], size_t nx)
{
    fmu_instance *fi = c;
    const fmu_me *me = FMU_MODEL.me;
    if (!me_instance(fi, "fmi2GetNominalsOfContinuousStates") ||
        !allowed(fi, "fmi2GetNominalsOfContinuousStates", ANY_STATE))
        return fmi2Error;
    if (!count_is(fi, "fmi2GetNominalsOfContinuousStates", "nx", nx, me->n_states) || (nx && !x_nominal))
        return fmi2Error;
    for (size_t i = 0; i < nx; i++) x_nominal[i] = me->nominal[i];
    return fmi2OK;
}
