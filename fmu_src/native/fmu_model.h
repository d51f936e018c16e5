/* fmu_src/native/fmu_model.h: what a native model gives the FMI plumbing (fmi2.c) and
 * what the plumbing gives it back.
 *
 * A model is one C file (fmu_src/ballinshell.c, drive_models/motorstartup.c, ...) that
 * defines `const fmu_model FMU_MODEL`. Its variables come from the interface header
 * that `ballmill build` generates from the one declaration (ballmill/fmi/interface.py):
 * value references VR_<name>, the table FMU_VARIABLES, the model identifier and GUID.
 *
 * The plumbing keeps every variable's value in one array `double v[]` indexed by value
 * reference (Integers and Booleans as exact doubles), checks every FMI call against the
 * instance's state, checks the declared bounds of every parameter before `setup`, runs
 * each step on a copy of v and the model's data and keeps the copy only when the step
 * succeeds, and saves/restores FMU states. The model's data is one block of plain
 * values (no pointers): the configuration that `setup` derives from the parameters,
 * then, from `dyn_offset` on, the dynamic state that FMU states carry.
 */
#ifndef BALLMILL_FMU_MODEL_H
#define BALLMILL_FMU_MODEL_H

#include <stddef.h>

#include "fmi2Functions.h"

typedef enum { FMU_REAL, FMU_INTEGER, FMU_BOOLEAN } fmu_type;
/* FMU_LOCAL: Model Exchange's continuous states and their derivatives (interface.ModelExchange) */
typedef enum { FMU_PARAMETER, FMU_INPUT, FMU_OUTPUT, FMU_LOCAL } fmu_causality;

typedef struct {
    const char *name;
    fmu_type type;
    fmu_causality causality;
    int tunable;       /* parameter that may change after initialisation */
    int discrete;      /* discrete variability (Integers, Booleans): in Model Exchange such an
                        * output changes only at events (initialisation, the event update) */
    double start;
    double min, max;   /* declared bounds; -INFINITY / INFINITY when none */
    const char *unit;  /* "" when none */
} fmu_variable;

typedef struct fmu_instance fmu_instance;

/* what an event update found (Model Exchange) */
typedef struct {
    int terminate;          /* the model cannot continue */
    int states_changed;     /* the continuous states in v were changed (re-initialised) */
    int next_time_defined;  /* a time event is due at next_time (> the event's time) */
    double next_time;
} fmu_event;

/* Model Exchange: a model's continuous states and event indicators (their value references
 * and nominals come from the generated interface header: FMU_N_STATES, FMU_STATE_VRS,
 * FMU_DERIVATIVE_VRS, FMU_STATE_NOMINALS, FMU_N_INDICATORS). The continuous states live in
 * v at their value references, their derivatives at theirs: FMU states carry them with v.
 * Inputs are read from v at every call, as the importer set them (no reconstruction). */
typedef struct {
    int n_states, n_indicators;
    const int *state_vr, *der_vr; /* n_states each */
    const double *nominal;        /* n_states */
    const int *indicator_vr;      /* n_indicators: the variables that show the event indicators */
    /* after setup (FMU_SETUP_START) at fmi2ExitInitializationMode: refuse (fmi2Error after
     * fmu_log said why) a configuration Model Exchange does not support; write the start
     * state into v at state_vr; NULL for a model without continuous states that runs every
     * configuration in Model Exchange */
    fmi2Status (*start)(fmu_instance *fi, void *data, double *v, double t);
    /* at time t, from the states and inputs in v: the outputs and the derivatives into v, the
     * event indicators into z (n_indicators; NULL: not wanted). fmi2OK, or fmi2Error after
     * fmu_log said why (an input or state it cannot use); the plumbing then keeps v as it was.
     * The discrete outputs eval writes are taken only at an event update: between events the
     * plumbing keeps those of the last event (FMI: discrete variables change at events only) */
    fmi2Status (*eval)(fmu_instance *fi, void *data, double *v, double t, double *z);
    /* event mode at time t, after eval: update the discrete state (e.g. a validity latch,
     * logging why). fmi2OK / fmi2Warning. NULL: no discrete state. */
    fmi2Status (*event)(fmu_instance *fi, void *data, double *v, double t, fmu_event *ev);
    /* the first time event strictly after t (a drive law's kink or switch), INFINITY when none;
     * NULL: no time events. Model Exchange's event update announces it (next_time); FMI 3
     * co-simulation with early return ends a step there */
    double (*next_time)(const void *data, double t);
} fmu_me;

typedef struct {
    const char *identifier;
    const char *guid;
    int n_vars;
    const fmu_variable *vars;
    size_t data_size;  /* bytes of the model's data */
    size_t dyn_offset; /* the dynamic state starts here */
    /* Build the configuration from the parameters in v (bounds already checked) and the
     * start state at time t; publish the outputs at t from the inputs in v.
     * fmi2OK, or fmi2Error after fmu_log said why. fmu_setup_kind says why it runs: the
     * start (its messages belong to fmi2ExitInitializationMode only), or the configuration
     * alone for fmi2SetFMUstate (the dynamic state, the outputs and the inputs then come
     * from the FMU state: nothing about the start is computed, checked or logged). */
    fmi2Status (*setup)(fmu_instance *fi, void *data, double *v, double t);
    /* One communication step t -> t_end (t the instance's time, t_end = the master's
     * currentCommunicationPoint + communicationStepSize > t: what the Python flavour's
     * Slave.do_step computes, so that both flavours step between the same times).
     * fmi2OK / fmi2Warning: the plumbing keeps data and v; fmi2Discard / fmi2Error:
     * it drops them (the last good state stays). */
    fmi2Status (*step)(fmu_instance *fi, void *data, double *v, double t, double t_end);
    /* A dynamic state restored from an FMU state into a freshly set up configuration:
     * fmi2OK when it is one this configuration can continue from, else fmi2Error after
     * fmu_log said why. NULL: nothing to check (no dynamic state beyond the plumbing's
     * time; the configuration is setup's, which has checked it). */
    fmi2Status (*check)(fmu_instance *fi, const void *data, const double *v);
    /* Direct feedthrough (NULL: none): inputs were set between steps (stepComplete);
     * recompute, at the instance's time t, the outputs the interface declares as
     * depending on them (ModelStructure/Outputs), from data and v. Leave v as it is when
     * the inputs are unusable (the next step refuses them). The model may record in its
     * dynamic state what the outputs were recomputed from (FMU states carry it). fmi2OK. */
    fmi2Status (*inputs_set)(fmu_instance *fi, void *data, double *v, double t);
    /* Model Exchange (NULL: co-simulation only) */
    const fmu_me *me;
} fmu_model;

extern const fmu_model FMU_MODEL;

/* log through the host's logger (warnings and worse always, OK-level messages when
 * debug logging is on); printf format */
void fmu_log(fmu_instance *fi, fmi2Status status, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 3, 4)))
#endif
    ;
const char *fmu_instance_name(const fmu_instance *fi);

/* whether the instance runs as Model Exchange (1) or co-simulation (0) */
int fmu_is_me(const fmu_instance *fi);

/* during a step: the communicationStepSize the master passed, and the call as
 * "doStep(currentCommunicationPoint = <tc> s, communicationStepSize = <h> s)" in buf
 * unless buf is NULL (formatting costs microseconds: only for messages) */
double fmu_step_call(const fmu_instance *fi, char buf[160]);

/* why setup runs: FMU_SETUP_START at fmi2ExitInitializationMode (the start state, its
 * outputs, checks and messages); FMU_SETUP_PREVIEW for a read in initialisation mode (the
 * same outputs from the inputs set so far; a failure is reported, the start's warnings are
 * left to fmi2ExitInitializationMode); FMU_SETUP_RESTORE in fmi2SetFMUstate (the
 * configuration from the state's parameters only) */
typedef enum { FMU_SETUP_START, FMU_SETUP_PREVIEW, FMU_SETUP_RESTORE } fmu_setup_kind_t;
fmu_setup_kind_t fmu_setup_kind(const fmu_instance *fi);

/* x as Python's repr(float) writes it (1.0, 0.3, 1e-05, nan, inf), for messages */
const char *fmu_repr(double x, char buf[32]);

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

#define FMU_BIG 1e300 /* stands for infinity in outputs (FMI tools choke on inf) */

#endif
