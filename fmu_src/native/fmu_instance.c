/* fmu_src/native/fmu_instance.c: the FMI plumbing (co-simulation and Model Exchange) of every
 * native ballmill FMU, written once for every FMI version (fmi2.c and fmi3.c translate their
 * functions to these; fmu_instance.h).
 *
 * Written once for all models (fmu_model.h is the contract): the fmi2 functions, one
 * state machine that checks every call against the instance's state, logging,
 * parameter bounds, atomic steps (a refused step keeps the last good state), and FMU
 * states with their serialisation (layout, checksum and check in fmu_state.c; restored
 * states are rebuilt and checked like at initialisation). Nothing here knows physics.
 *
 * Semantics (FMI 2.0 section 4.2.4 for the allowed calls, FMI 3.0's the same with its names;
 * "fmi2X" below is the version's function):
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
 *     restore an FMU state;
 *   - FMI 3 early return (the importer allows it): a step ends at its first event, a time event
 *     or a discrete (Boolean) output's change located by bisection (step_to_event), as if the master had
 *     asked for the step to that time.
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
 *   - the discrete outputs (Booleans, Integers) change only there and at initialisation: between
 *     events they hold, the continuous outputs follow every evaluation;
 *   - reading a continuous state, derivative or event indicator in co-simulation: the value at the
 *     co-simulation's own state (cs_locals), the same number Model Exchange gives at that time,
 *     state and inputs.
 */
#include <math.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmu_instance.h"
#include "fmu_model.h"
#include "fmu_state.h"

const char *fmu_state_name(const fmu_instance *fi, int s)
{
    if (fi && fi->fmi == 3) switch (s) { /* FMI 3.0's names of its states */
        case S_INSTANTIATED: return "Instantiated";
        case S_INIT: return "Initialization Mode";
        case S_STEP_COMPLETE: return "Step Mode";
        case S_STEP_FAILED: return "Step Discarded";
        case S_TERMINATED: return "Terminated";
        case S_ERROR: return "error";
        case S_EVENT: return "Event Mode";
        case S_CONT: return "Continuous-Time Mode";
        default: return "fatal";
        }
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

const char *fmu_fn(fmu_instance *fi, const char *suffix)
{
    char *buf = fi->fn_buf[fi->fn_next];
    fi->fn_next = (fi->fn_next + 1) % 4;
    snprintf(buf, sizeof fi->fn_buf[0], "fmi%d%s", fi->fmi, suffix);
    return buf;
}

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
    if (!fi || !fi->emit) return;
    if (status == fmi2OK && !fi->logging_on) return;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    if (fi->holding) { /* emitted later (step_to_event), or dropped with the trial step */
        if (fi->n_held < (int)(sizeof fi->held / sizeof fi->held[0])) {
            fi->held[fi->n_held].status = status;
            snprintf(fi->held[fi->n_held].text, sizeof fi->held[0].text, "%s", msg);
            fi->n_held++;
        }
        return;
    }
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
    fi->emit(fi, status, category, esc);
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
int fmu_allowed(fmu_instance *fi, const char *function, int states)
{
    if (!fi) return 0;
    if (fi->state & states) return 1;
    fmu_log(fi, fmi2Error, "%s '%s': %s is not allowed in state %s", FMU_MODEL.identifier, fi->name,
            function, fmu_state_name(fi, fi->state));
    return 0;
}
#define allowed fmu_allowed

/* the FMU's time t_c and a doStep's currentCommunicationPoint agree when they differ by at
 * most T_REL max(1 s, |t_c|) (a master's own time arithmetic; slave.T_REL) */
#define T_REL 1e-13

#define ME_RUNNING (S_EVENT | S_CONT | S_TERMINATED) /* Model Exchange after initialisation */
/* co-simulation after initialisation (a refused step keeps the last good state) */
#define CS_RUNNING (S_STEP_COMPLETE | S_STEP_FAILED | S_EVENT | S_TERMINATED | S_ERROR)

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

/* Model Exchange: the outputs, derivatives and event indicators at the instance's time from the
 * states and inputs in v, into the work copies (v_work, z_work), checked: fmi2OK when the model
 * accepts them and every output, derivative and indicator is finite. The discrete outputs
 * (Booleans, Integers: FMI 2.0 section 3.1, FMI 3.0 section 2.2.2) change only at events: between
 * events they keep the values of the last event update or of initialisation, whatever the
 * evaluation says (BallInShell's `rolling` would flip eps before its indicator's root, where
 * the importer has not yet handled the event); at an event update (at_event) they are taken. */
static fmi2Status me_evaluate_work(fmu_instance *fi, const char *function, int at_event)
{
    const fmu_me *me = FMU_MODEL.me;
    size_t nv = (size_t)FMU_MODEL.n_vars * sizeof(double);
    memcpy(fi->v_work, fi->v, nv);
    if (me->eval(fi, fi->data, fi->v_work, fi->t, fi->z_work) > fmi2Warning) {
        fmu_log(fi, fmi2Error, "%s '%s': %s: the model could not be evaluated at t = %.17g s (see the message "
                "before); last good values kept", FMU_MODEL.identifier, fi->name, function, fi->t);
        return fmi2Error;
    }
    for (int i = 0; i < me->n_indicators; i++) fi->v_work[me->indicator_vr[i]] = fi->z_work[i];
    for (int i = 0; i < FMU_MODEL.n_vars; i++) {
        const fmu_variable *var = &FMU_MODEL.vars[i];
        if (!at_event && var->discrete && var->causality == FMU_OUTPUT) fi->v_work[i] = fi->v[i];
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
    return fmi2OK;
}

/* Model Exchange: evaluate (me_evaluate_work) when the time, a state or an input changed since
 * the last evaluation, and commit */
static fmi2Status me_evaluate(fmu_instance *fi, const char *function)
{
    if (!fi->dirty) return fmi2OK;
    if (me_evaluate_work(fi, function, 0) != fmi2OK) return fmi2Error;
    double *tv = fi->v;
    fi->v = fi->v_work;
    fi->v_work = tv;
    double *tz = fi->z;
    fi->z = fi->z_work;
    fi->z_work = tz;
    fi->dirty = 0;
    return fmi2OK;
}

/* Co-simulation: the Model Exchange variables (continuous states, derivatives, event
 * indicators) that the model description publishes for both interfaces, from the
 * co-simulation's own state: the model's `start` writes the continuous states its data holds
 * (the state at the last communication point) into a copy of v, `eval` gives the derivatives
 * there with the inputs as set now, and the event indicators: the numbers a Model Exchange
 * instance gives at the same time, states and inputs. On the work copies (the result in
 * v_work): the co-simulation's values and data stay as they are. A configuration Model
 * Exchange does not support has none of these variables: fmi2Error after the model said why. */
static fmi2Status cs_locals(fmu_instance *fi, const char *function, const unsigned int vr[], size_t nvr)
{
    const fmu_me *me = FMU_MODEL.me;
    size_t nv = (size_t)FMU_MODEL.n_vars * sizeof(double);
    const char *name = FMU_MODEL.vars[vr[0]].name;
    for (size_t i = 0; i < nvr; i++)
        if (FMU_MODEL.vars[vr[i]].causality == FMU_LOCAL) {
            name = FMU_MODEL.vars[vr[i]].name;
            break;
        }
    fmi2Status s = fmi2Error;
    if (me) {
        memcpy(fi->v_work, fi->v, nv);
        memcpy(fi->data_work, fi->data, FMU_MODEL.data_size);
        s = me->start ? me->start(fi, fi->data_work, fi->v_work, fi->t) : fmi2OK;
        if (s <= fmi2Warning) s = me->eval(fi, fi->data_work, fi->v_work, fi->t, fi->z_work);
        memcpy(fi->data_work, fi->data, FMU_MODEL.data_size); /* keep the copies equal */
        for (int i = 0; s <= fmi2Warning && i < me->n_indicators; i++) fi->v_work[me->indicator_vr[i]] = fi->z_work[i];
        for (size_t i = 0; s <= fmi2Warning && i < nvr; i++)
            if (FMU_MODEL.vars[vr[i]].causality == FMU_LOCAL && !isfinite(fi->v_work[vr[i]])) {
                char a[32], b[32];
                fmu_log(fi, fmi2Error, "%s '%s': %s: %s would be %s at t = %s s", FMU_MODEL.identifier, fi->name,
                        function, FMU_MODEL.vars[vr[i]].name, fmu_repr(fi->v_work[vr[i]], a), fmu_repr(fi->t, b));
                s = fmi2Error;
            }
    }
    if (s <= fmi2Warning) return fmi2OK;
    fmu_log(fi, fmi2Error, "%s '%s': %s: %s refused: this co-simulation instance could not evaluate its Model "
            "Exchange variables at t = %.17g s (see the message before)", FMU_MODEL.identifier, fi->name, function,
            name, fi->t);
    return fmi2Error;
}

/* ------------------------------------------------------------------ life cycle */

void fmu_free_instance(fmu_instance *fi)
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



fmu_instance *fmu_instantiate(const char *fn, const char *instanceName, const char *token, int me, int fmi,
                              fmu_emit_fn emit, void *logger, void *env, int loggingOn)
{
    fmu_instance tmp;
    memset(&tmp, 0, sizeof tmp);
    tmp.name = (char *)(instanceName ? instanceName : "?");
    tmp.fmi = fmi;
    tmp.emit = emit;
    tmp.logger = logger;
    tmp.env = env;
    if (!instanceName || !*instanceName) {
        fmu_log(&tmp, fmi2Error, "%s: %s: the instance name must not be empty", FMU_MODEL.identifier, fn);
        return NULL;
    }
    if (!token || strcmp(token, FMU_MODEL.guid) != 0) {
        fmu_log(&tmp, fmi2Error, "%s '%s': %s: %s %s does not match this binary's %s", FMU_MODEL.identifier,
                instanceName, fn, fmi == 2 ? "GUID" : "instantiationToken", token ? token : "(null)",
                FMU_MODEL.guid);
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
        fmu_free_instance(fi);
        fmu_log(&tmp, fmi2Fatal, "%s '%s': %s: out of memory", FMU_MODEL.identifier, instanceName, fn);
        return NULL;
    }
    strcpy(fi->name, instanceName);
    fi->fmi = fmi;
    fi->emit = emit;
    fi->logger = logger;
    fi->env = env;
    fi->logging_on = loggingOn ? 1 : 0;
    fi->state = S_INSTANTIATED;
    fi->me = me;
    fi->dirty = 1;
    start_values(fi);
    return fi;
}

fmi2Status fmu_set_debug_logging(fmu_instance *fi, const char *fn, int loggingOn)
{
    if (!allowed(fi, fn, ANY_STATE)) return fmi2Error;
    fi->logging_on = loggingOn ? 1 : 0;
    return fmi2OK;
}

fmi2Status fmu_setup_experiment(fmu_instance *fi, const char *fn, double startTime)
{
    char a[32];
    if (!allowed(fi, fn, S_INSTANTIATED)) return fmi2Error;
    if (!isfinite(startTime)) {
        fmu_log(fi, fmi2Error, "%s '%s': %s: startTime = %s s must be finite",
                FMU_MODEL.identifier, fi->name, fn, fmu_repr(startTime, a));
        return fmi2Error;
    }
    fi->t_start = fi->t = startTime;
    return fmi2OK;
}

fmi2Status fmu_enter_initialization_mode(fmu_instance *fi, const char *fn)
{
    if (!allowed(fi, fn, S_INSTANTIATED)) return fmi2Error;
    fi->state = S_INIT;
    fi->built = 0;
    return fmi2OK;
}

fmi2Status fmu_exit_initialization_mode(fmu_instance *fi, const char *fn)
{
    if (!allowed(fi, fn, S_INIT)) return fmi2Error;
    fmi2Status s = build(fi, FMU_SETUP_START);
    if (s > fmi2Warning) return fmi2Error; /* stays in initialisation mode: fix the parameters and retry */
    if (fi->me) {
        /* Model Exchange: the model's start state (after its check of what it supports) */
        size_t nv = (size_t)FMU_MODEL.n_vars * sizeof(double);
        memcpy(fi->v_work, fi->v, nv);
        fmi2Status m = FMU_MODEL.me->start ? FMU_MODEL.me->start(fi, fi->data, fi->v_work, fi->t) : fmi2OK;
        if (m > fmi2Warning) return fmi2Error;
        memcpy(fi->v, fi->v_work, nv);
        fi->dirty = 1;
        if (me_evaluate(fi, fn) != fmi2OK) return fmi2Error;
        fi->t_accepted = fi->t;
        fi->state = S_EVENT; /* FMI 2.0: initialisation ends in event mode */
        return m > s ? m : s;
    }
    fi->state = fi->cs_event_mode ? S_EVENT : S_STEP_COMPLETE; /* FMI 3 with event mode: event mode */
    return s;
}

fmi2Status fmu_terminate(fmu_instance *fi, const char *fn)
{
    if (!allowed(fi, fn, S_STEP_COMPLETE | S_STEP_FAILED | S_EVENT | S_CONT)) return fmi2Error;
    fi->state = S_TERMINATED;
    return fmi2OK;
}

fmi2Status fmu_reset(fmu_instance *fi, const char *fn)
{
    if (!allowed(fi, fn, ANY_STATE)) return fmi2Error;
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

static fmi2Status check_vr(fmu_instance *fi, const char *function, unsigned int vr, fmu_type type)
{
    if (vr >= (unsigned int)FMU_MODEL.n_vars) {
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

fmi2Status fmu_get(fmu_instance *fi, const char *function, const unsigned int vr[],
                             size_t nvr, fmu_type type, double *out)
{
    if (!allowed(fi, function, READABLE)) return fmi2Error;
    if (nvr && (!vr || !out)) return fmi2Error;
    for (size_t i = 0; i < nvr; i++)
        if (check_vr(fi, function, vr[i], type) != fmi2OK) return fmi2Error;
    int local = 0;
    for (size_t i = 0; i < nvr; i++) {
        const fmu_variable *var = &FMU_MODEL.vars[vr[i]];
        if (var->causality != FMU_LOCAL) continue;
        local = 1;
        if (fi->built && (fi->state & (fi->me ? ME_RUNNING : CS_RUNNING))) continue;
        fmu_log(fi, fmi2Error, "%s '%s': %s: %s is a Model Exchange variable (a continuous state, its "
                "derivative or an event indicator): it is known from the end of initialisation on, not in "
                "state %s", FMU_MODEL.identifier, fi->name, function, var->name, fmu_state_name(fi, fi->state));
        return fmi2Error;
    }
    if (fi->state == S_INIT && build(fi, FMU_SETUP_PREVIEW) > fmi2Warning) /* outputs consistent with the inputs set so far */
        return fmi2Error;
    if (fi->me && (fi->state & ME_RUNNING) && me_evaluate(fi, function) != fmi2OK) return fmi2Error;
    if (!fi->me && local) { /* co-simulation: the Model Exchange variables of its own state */
        if (cs_locals(fi, function, vr, nvr) != fmi2OK) return fmi2Error;
        for (size_t i = 0; i < nvr; i++)
            out[i] = FMU_MODEL.vars[vr[i]].causality == FMU_LOCAL ? fi->v_work[vr[i]] : fi->v[vr[i]];
        return fmi2OK;
    }
    for (size_t i = 0; i < nvr; i++) out[i] = fi->v[vr[i]];
    return fmi2OK;
}

/* may vr be set now? A fixed parameter only before the end of initialisation, an input
 * from instantiation on, an output never. */
static fmi2Status settable(fmu_instance *fi, const char *function, unsigned int vr, double x)
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
                 "%s (got %s = %s%s%s)", var->name, fmu_fn(fi, "SetContinuousStates"), var->name,
                 value_text(var, x, a), sep, unit);
    else if (var->causality == FMU_PARAMETER && !var->tunable && initialised)
        snprintf(why, sizeof why, "parameter %s is fixed: it can be set only before %s "
                 "(%s, then set it); %s = %s%s%s refused, %s keeps %s%s%s", var->name,
                 fmu_fn(fi, "ExitInitializationMode"), fmu_fn(fi, "Reset"), var->name,
                 value_text(var, x, a), sep, unit, var->name, value_text(var, fi->v[vr], b), sep, unit);
    else if (var->causality == FMU_PARAMETER && var->tunable && initialised && !in_range(var, x))
        snprintf(why, sizeof why, "tunable parameter %s = %s%s%s refused: accepted range %s; %s keeps %s%s%s",
                 var->name, value_text(var, x, a), sep, unit, range_text(var, range), var->name,
                 value_text(var, fi->v[vr], b), sep, unit);
    if (!why[0]) return fmi2OK;
    fmu_log(fi, fmi2Error, "%s '%s': %s: %s cannot be set in state %s: %s", FMU_MODEL.identifier, fi->name,
            function, var->name, fmu_state_name(fi, fi->state), why);
    return fmi2Error;
}

fmi2Status fmu_set(fmu_instance *fi, const char *function, const unsigned int vr[],
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
    if (input && (fi->state & (S_STEP_COMPLETE | S_EVENT)) && FMU_MODEL.inputs_set) /* FMI 3: step or event mode */
        return FMU_MODEL.inputs_set(fi, fi->data, fi->v, fi->t);
    return fmi2OK;
}









/* ------------------------------------------------------------------ stepping */
/* one step from the committed state (fi->t) to t_end on the work copies: the model's step and
 * the check of its outputs. The configuration part of the data is the same in both copies
 * (build and fmi2SetFMUstate write both), so only the dynamic part is copied. */
static fmi2Status try_step(fmu_instance *fi, double t_end)
{
    size_t nv = (size_t)FMU_MODEL.n_vars * sizeof(double);
    memcpy(fi->v_work, fi->v, nv);
    memcpy(fi->data_work + FMU_MODEL.dyn_offset, fi->data + FMU_MODEL.dyn_offset,
           FMU_MODEL.data_size - FMU_MODEL.dyn_offset);
    fmi2Status s = FMU_MODEL.step(fi, fi->data_work, fi->v_work, fi->t, t_end);
    if (s <= fmi2Warning && check_outputs(fi, fi->v_work, t_end) != fmi2OK) s = fmi2Discard;
    return s;
}

/* the step on the work copies changed a discrete output (validity, contact, rolling): an event */
static int discrete_changed(const fmu_instance *fi)
{
    for (int i = 0; i < FMU_MODEL.n_vars; i++)
        if (FMU_MODEL.vars[i].causality == FMU_OUTPUT && FMU_MODEL.vars[i].discrete && fi->v[i] != fi->v_work[i])
            return 1;
    return 0;
}

/* the located event time: within T_EVENT max(1 s, |t|) after the last step end without it */
#define T_EVENT 1e-12

/* FMI 3 early return: the step to *t_end, ended at the first event in it instead: a time event
 * (the model's next_time), else where a discrete (Boolean) output changes, located by bisection over the
 * step's end: each trial is a step from the committed state to a shorter end, as if the master
 * had asked for it, and the step kept is the shortest one with the change. Only the kept step's
 * messages reach the host. Without an event the step is the one without early return. */
static fmi2Status step_to_event(fmu_instance *fi, double *t_end)
{
    const double t = fi->t, tol = T_EVENT * fmax(1.0, fabs(*t_end));
    double hi = *t_end;
    if (FMU_MODEL.me && FMU_MODEL.me->next_time) {
        double next = FMU_MODEL.me->next_time(fi->data, t);
        if (next > t + tol && next < hi - tol) hi = next;
    }
    fi->holding = 1;
    fi->n_held = 0;
    fmi2Status s = try_step(fi, hi);
    if (s <= fmi2Warning && discrete_changed(fi)) {
        double lo = t;
        while (hi - lo > tol) {
            double mid = lo + 0.5 * (hi - lo);
            fi->n_held = 0;
            fmi2Status m = try_step(fi, mid);
            if (m > fmi2Warning) break; /* a shorter step failed: keep the longer one found */
            if (discrete_changed(fi)) hi = mid; else lo = mid;
        }
        fi->n_held = 0;
        s = try_step(fi, hi);
    }
    fi->holding = 0;
    for (int i = 0; i < fi->n_held; i++) fmu_log(fi, fi->held[i].status, "%s", fi->held[i].text);
    fi->n_held = 0;
    *t_end = hi;
    return s;
}

fmi2Status fmu_do_step(fmu_instance *fi, const char *fn, double currentCommunicationPoint,
                       double communicationStepSize)
{
    char a[32], b[32];
    double t = currentCommunicationPoint, h = communicationStepSize;
    if (fi && fi->state == S_TERMINATED) {
        fmu_log(fi, fmi2Error, "%s '%s': %s(currentCommunicationPoint = %s s, communicationStepSize = "
                "%s s) after %s refused: %s is not allowed in state %s",
                FMU_MODEL.identifier, fi->name, fn, fmu_repr(t, a), fmu_repr(h, b), fmu_fn(fi, "Terminate"), fn,
                fmu_state_name(fi, S_TERMINATED));
        return fmi2Error;
    }
    if (!allowed(fi, fn, S_STEP_COMPLETE)) return fmi2Error;
    if (!(isfinite(h) && h > 0.0)) {
        fmu_log(fi, fmi2Error, "%s '%s': %s: communicationStepSize = %s s refused: it must be positive "
                "and finite; state unchanged", FMU_MODEL.identifier, fi->name, fn, fmu_repr(h, a));
        return fmi2Error;
    }
    if (!(fabs(t - fi->t) <= T_REL * fmax(1.0, fabs(fi->t)))) {
        fmu_log(fi, fmi2Error, "%s '%s': %s: currentCommunicationPoint = %s s refused: "
                "currentCommunicationPoint must equal the FMU's time t = %s s (steps are contiguous; restore an "
                "FMU state to go back); state unchanged",
                FMU_MODEL.identifier, fi->name, fn, fmu_repr(t, a), fmu_repr(fi->t, b));
        return fmi2Error;
    }
    double t_end = t + h;
    if (!(t_end > fi->t)) {
        fmu_log(fi, fmi2Error, "%s '%s': %s: the step ends at %s s, not after the FMU's time t = %s s; "
                "state unchanged", FMU_MODEL.identifier, fi->name, fn, fmu_repr(t_end, a), fmu_repr(fi->t, b));
        return fmi2Error;
    }
    fi->call_t = t;
    fi->call_h = h;
    fi->returned_early = 0;
    /* from the FMU's time to the master's end of the step (slave.Slave.do_step), or, when the
     * importer allows early return, to the first event in it */
    double t_stop = t_end;
    fmi2Status s = fi->cs_early_return ? step_to_event(fi, &t_stop) : try_step(fi, t_end);
    if (s > fmi2Warning) return s == fmi2Discard ? fmi2Discard : fmi2Error; /* the last good state stays */
    fi->step_event = discrete_changed(fi) || t_stop < t_end; /* an event FMI 3's event mode reports */
    fi->returned_early = t_stop < t_end;
    t_end = t_stop;
    double *tv = fi->v;
    fi->v = fi->v_work;
    fi->v_work = tv;
    unsigned char *td = fi->data;
    fi->data = fi->data_work;
    fi->data_work = td;
    fi->t = t_end;
    return s;
}










/* ------------------------------------------------------------------ FMU states */
/* The layout, checksum and check of a state are fmu_state.c's; here: which instance states
 * a state may carry, and what the fmi2 calls do with one. */
/* the instance states an FMU state may carry: those of the instance's interface */
#define STATE_PHASES (S_INSTANTIATED | S_INIT | S_TERMINATED | (fi->me ? S_EVENT | S_CONT : S_STEP_COMPLETE | S_STEP_FAILED \
                                                                                     | (fi->cs_event_mode ? S_EVENT : 0)))

fmi2Status fmu_get_state(fmu_instance *fi, const char *fn, void **state)
{
    if (!allowed(fi, fn, ANY_STATE)) return fmi2Error;
    if (!state) return fmi2Error;
    unsigned char *b = *state ? *state : malloc(fmu_state_size()); /* a given state is overwritten */
    if (!b) {
        fmu_log(fi, fmi2Error, "%s '%s': %s: out of memory", FMU_MODEL.identifier, fi->name, fn);
        return fmi2Error;
    }
    fmu_state_write(b, (uint32_t)fi->fmi, (int32_t)fi->state, fi->built, fi->t_start, fi->t, fi->v, fi->data);
    *state = b;
    return fmi2OK;
}

fmi2Status fmu_set_state(fmu_instance *fi, const char *fn, const void *state)
{
    const unsigned char *b = state;
    if (!allowed(fi, fn, ANY_STATE)) return fmi2Error;
    char why[FMU_STATE_WHY];
    if (fmu_state_check(b, fmu_state_size(), (uint32_t)fi->fmi, STATE_PHASES, 0, why)) {
        fmu_log(fi, fmi2Error, "%s '%s': %s: state refused, instance unchanged: %s",
                FMU_MODEL.identifier, fi->name, fn, why);
        return fmi2Error;
    }
    fmu_state_header h;
    fmu_state_header_of(b, &h);
    if (h.built && h.phase == S_INSTANTIATED) { /* nothing is built before initialisation: a state never written */
        fmu_log(fi, fmi2Error, "%s '%s': %s: state refused, instance unchanged: built flag 1 in state %s, "
                "expected 0 (the model is set up when initialisation ends)", FMU_MODEL.identifier, fi->name, fn,
                fmu_state_name(fi, S_INSTANTIATED));
        return fmi2Error;
    }
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
    fmu_log(fi, fmi2Error, "%s '%s': %s: state refused (see the message before), instance unchanged",
            FMU_MODEL.identifier, fi->name, fn);
    return fmi2Error;
}

fmi2Status fmu_free_state(fmu_instance *fi, const char *fn, void **state)
{
    if (!allowed(fi, fn, ANY_STATE)) return fmi2Error;
    if (state) {
        free(*state);
        *state = NULL;
    }
    return fmi2OK;
}

fmi2Status fmu_serialized_size(fmu_instance *fi, const char *fn, size_t *size)
{
    if (!allowed(fi, fn, ANY_STATE) || !size) return fmi2Error;
    *size = fmu_state_size();
    return fmi2OK;
}

fmi2Status fmu_serialize(fmu_instance *fi, const char *fn, const void *state, unsigned char *serializedState, size_t size)
{
    if (!allowed(fi, fn, ANY_STATE)) return fmi2Error;
    char why[FMU_STATE_WHY];
    if (!fmu_state_check(state, fmu_state_size(), (uint32_t)fi->fmi, STATE_PHASES, 0, why)) {
        if (!serializedState) snprintf(why, sizeof why, "no buffer given");
        else if (size < fmu_state_size())
            snprintf(why, sizeof why, "the buffer has %zu bytes, fewer than %s = %zu", size, fmu_fn(fi, "SerializedFMUstateSize"),
                     fmu_state_size());
    }
    if (*why) {
        fmu_log(fi, fmi2Error, "%s '%s': %s: %s", FMU_MODEL.identifier, fi->name, fn, why);
        return fmi2Error;
    }
    memcpy(serializedState, state, fmu_state_size());
    fmu_state_seal((unsigned char *)serializedState); /* the checksum: only serialised states carry it */
    return fmi2OK;
}

fmi2Status fmu_deserialize(fmu_instance *fi, const char *fn, const unsigned char *serializedState, size_t size,
                           void **state)
{
    if (!allowed(fi, fn, ANY_STATE) || !state) return fmi2Error;
    char why[FMU_STATE_WHY];
    if (fmu_state_check((const unsigned char *)serializedState, size, (uint32_t)fi->fmi, STATE_PHASES, 1, why)) {
        fmu_log(fi, fmi2Error, "%s '%s': %s: state refused: %s", FMU_MODEL.identifier,
                fi->name, fn, why);
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

/* event mode: Model Exchange from continuous-time mode; FMI 3 co-simulation with event mode
 * from step mode (after a step that reported an event, or whenever the importer wants) */
fmi2Status fmu_enter_event_mode(fmu_instance *fi, const char *fn)
{
    if (fi && !fi->me && fi->cs_event_mode) {
        if (!allowed(fi, fn, S_STEP_COMPLETE)) return fmi2Error;
        fi->state = S_EVENT;
        return fmi2OK;
    }
    if (!me_instance(fi, fn) || !allowed(fi, fn, S_CONT)) return fmi2Error;
    fi->state = S_EVENT;
    return fmi2OK;
}

/* FMI 3 co-simulation: event mode -> step mode */
fmi2Status fmu_enter_step_mode(fmu_instance *fi, const char *fn)
{
    if (!allowed(fi, fn, S_EVENT)) return fmi2Error;
    fi->state = S_STEP_COMPLETE;
    return fmi2OK;
}

fmi2Status fmu_update_discrete_states(fmu_instance *fi, const char *fn, fmu_event *info)
{
    if (fi && info && !fi->me && fi->cs_event_mode) {
        /* co-simulation: the step has already updated everything (the validity latch) */
        if (!allowed(fi, fn, S_EVENT)) return fmi2Error;
        memset(info, 0, sizeof *info);
        fi->step_event = 0;
        return fmi2OK;
    }
    if (!me_instance(fi, fn) || !allowed(fi, fn, S_EVENT) || !info)
        return fmi2Error;
    /* the outputs at the event, the discrete ones included, then the model's update; on the
     * work copy, committed together */
    if (me_evaluate_work(fi, fn, 1) != fmi2OK) return fmi2Error;
    fmu_event ev = {0, 0, 0, 0.0};
    fmi2Status s = FMU_MODEL.me->event ? FMU_MODEL.me->event(fi, fi->data, fi->v_work, fi->t, &ev) : fmi2OK;
    if (s > fmi2Warning) return fmi2Error;
    double next = FMU_MODEL.me->next_time ? FMU_MODEL.me->next_time(fi->data, fi->t) : INFINITY;
    if (isfinite(next)) {
        ev.next_time_defined = 1;
        ev.next_time = next;
    }
    double *tv = fi->v;
    fi->v = fi->v_work;
    fi->v_work = tv;
    fi->dirty = 1; /* the discrete state may have changed (the indicators' hysteresis side): evaluate again */
    fi->t_accepted = fi->t;
    *info = ev; /* one update settles every event of these models */
    return s;
}

fmi2Status fmu_enter_continuous_time_mode(fmu_instance *fi, const char *fn)
{
    if (!me_instance(fi, fn) || !allowed(fi, fn, S_EVENT))
        return fmi2Error;
    fi->state = S_CONT;
    return fmi2OK;
}

fmi2Status fmu_completed_integrator_step(fmu_instance *fi, const char *fn, int *enterEventMode, int *terminateSimulation)
{
    if (!me_instance(fi, fn) || !allowed(fi, fn, S_CONT))
        return fmi2Error;
    fi->t_accepted = fi->t;
    if (enterEventMode) *enterEventMode = 0; /* every event is a state or time event */
    if (terminateSimulation) *terminateSimulation = 0;
    return fmi2OK;
}

fmi2Status fmu_set_time(fmu_instance *fi, const char *fn, double time)
{
    char a[32], b[32], d[32];
    if (!me_instance(fi, fn) || !allowed(fi, fn, S_EVENT | S_CONT)) return fmi2Error;
    if (!isfinite(time)) {
        fmu_log(fi, fmi2Error, "%s '%s': %s: time = %s s refused: it must be finite; time stays %s s",
                FMU_MODEL.identifier, fi->name, fn, fmu_repr(time, a), fmu_repr(fi->t, b));
        return fmi2Error;
    }
    if (time < fi->t_accepted - T_REL * fmax(1.0, fabs(fi->t_accepted))) {
        fmu_log(fi, fmi2Error, "%s '%s': %s: time = %s s refused: it is before the last accepted time "
                "%s s (the end of initialisation, the last completed integrator step or event); time stays %s s "
                "(restore an FMU state to go back)", FMU_MODEL.identifier, fi->name, fn, fmu_repr(time, a),
                fmu_repr(fi->t_accepted, b), fmu_repr(fi->t, d));
        return fmi2Error;
    }
    if (time != fi->t) fi->dirty = 1;
    fi->t = time;
    return fmi2OK;
}

fmi2Status fmu_set_continuous_states(fmu_instance *fi, const char *fn, const double x[], size_t nx)
{
    const fmu_me *me = FMU_MODEL.me;
    if (!me_instance(fi, fn)) return fmi2Error;
    if (fi->state == S_EVENT) {
        fmu_log(fi, fmi2Error, "%s '%s': %s is not allowed in state %s: the states "
                "are set in continuousTimeMode (in event mode only the FMU's event update changes them); "
                "states unchanged", FMU_MODEL.identifier, fi->name, fn, fmu_state_name(fi, fi->state));
        return fmi2Error;
    }
    if (!allowed(fi, fn, S_CONT)) return fmi2Error;
    if (!count_is(fi, fn, "nx", nx, me->n_states)) return fmi2Error;
    if (nx && !x) return fmi2Error;
    for (size_t i = 0; i < nx; i++)
        if (!isfinite(x[i])) {
            char a[32], b[32], d[32];
            const fmu_variable *var = &FMU_MODEL.vars[me->state_vr[i]];
            fmu_log(fi, fmi2Error, "%s '%s': %s: %s = %s%s%s refused at t = %s s: every "
                    "continuous state must be finite; states unchanged (%s keeps %s)", FMU_MODEL.identifier,
                    fi->name, fn, var->name, fmu_repr(x[i], a), *unit_text(var) ? " " : "", unit_text(var),
                    fmu_repr(fi->t, b), var->name, fmu_repr(fi->v[me->state_vr[i]], d));
            return fmi2Error;
        }
    for (size_t i = 0; i < nx; i++) {
        if (fi->v[me->state_vr[i]] != x[i]) fi->dirty = 1;
        fi->v[me->state_vr[i]] = x[i];
    }
    return fmi2OK;
}

fmi2Status fmu_get_continuous_states(fmu_instance *fi, const char *fn, double x[], size_t nx)
{
    const fmu_me *me = FMU_MODEL.me;
    if (!me_instance(fi, fn) || !allowed(fi, fn, ME_RUNNING))
        return fmi2Error;
    if (!count_is(fi, fn, "nx", nx, me->n_states) || (nx && !x)) return fmi2Error;
    for (size_t i = 0; i < nx; i++) x[i] = fi->v[me->state_vr[i]];
    return fmi2OK;
}

fmi2Status fmu_get_derivatives(fmu_instance *fi, const char *fn, double derivatives[], size_t nx)
{
    const fmu_me *me = FMU_MODEL.me;
    if (!me_instance(fi, fn) || !allowed(fi, fn, ME_RUNNING)) return fmi2Error;
    if (!count_is(fi, fn, "nx", nx, me->n_states) || (nx && !derivatives)) return fmi2Error;
    if (me_evaluate(fi, fn) != fmi2OK) return fmi2Error;
    for (size_t i = 0; i < nx; i++) derivatives[i] = fi->v[me->der_vr[i]];
    return fmi2OK;
}

fmi2Status fmu_get_event_indicators(fmu_instance *fi, const char *fn, double eventIndicators[], size_t ni)
{
    const fmu_me *me = FMU_MODEL.me;
    if (!me_instance(fi, fn) || !allowed(fi, fn, ME_RUNNING))
        return fmi2Error;
    if (!count_is(fi, fn, "ni", ni, me->n_indicators) || (ni && !eventIndicators))
        return fmi2Error;
    if (me_evaluate(fi, fn) != fmi2OK) return fmi2Error;
    for (size_t i = 0; i < ni; i++) eventIndicators[i] = fi->z[i];
    return fmi2OK;
}

fmi2Status fmu_get_nominals(fmu_instance *fi, const char *fn, double x_nominal[], size_t nx)
{
    const fmu_me *me = FMU_MODEL.me;
    if (!me_instance(fi, fn) ||
        !allowed(fi, fn, ANY_STATE))
        return fmi2Error;
    if (!count_is(fi, fn, "nx", nx, me->n_states) || (nx && !x_nominal))
        return fmi2Error;
    for (size_t i = 0; i < nx; i++) x_nominal[i] = me->nominal[i];
    return fmi2OK;
}
