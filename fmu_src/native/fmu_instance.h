/* fmu_src/native/fmu_instance.h: the plumbing every FMI version of every native ballmill FMU
 * shares (fmu_instance.c), written once: the instance and its life cycle, the state machine
 * that checks every call, the variable table with its bounds, get/set, the atomic
 * co-simulation step, Model Exchange's evaluation and events, FMU states. The FMI version's
 * own file (fmi2.c, fmi3.c) only translates its function signatures, types and callbacks to
 * these functions; `fn` is the name of the FMI function being run, for the messages.
 * Statuses are the model API's fmi2Status, numerically fmi3Status too (OK 0 .. Fatal 4). */
#ifndef BALLMILL_FMU_INSTANCE_H
#define BALLMILL_FMU_INSTANCE_H

#include <stddef.h>

#include "fmu_model.h"

/* instance states, one bit each (named per FMI version by fmu_state_name) */
typedef enum {
    S_INSTANTIATED = 1,
    S_INIT = 2,
    S_STEP_COMPLETE = 4, /* co-simulation: stepComplete (FMI 2), Step Mode (FMI 3) */
    S_STEP_FAILED = 8,
    S_TERMINATED = 16,
    S_ERROR = 32,
    S_FATAL = 64,
    S_EVENT = 128, /* event mode (Model Exchange; FMI 3 co-simulation with event mode) */
    S_CONT = 256   /* Model Exchange: continuous-time mode */
} fmu_state;

#define ANY_STATE (S_INSTANTIATED | S_INIT | S_STEP_COMPLETE | S_STEP_FAILED | S_TERMINATED | S_ERROR | S_EVENT | S_CONT)
#define READABLE (S_INIT | S_STEP_COMPLETE | S_STEP_FAILED | S_TERMINATED | S_ERROR | S_EVENT | S_CONT)

/* how the version's plumbing hands a message to its host's logger */
typedef void (*fmu_emit_fn)(fmu_instance *fi, fmi2Status status, const char *category, const char *message);

struct fmu_instance {
    char *name;
    int fmi;              /* FMI major version of the plumbing that instantiated it */
    fmu_emit_fn emit;
    void *logger, *env;   /* the host's logger and its environment (the version's types) */
    int logging_on;
    fmu_state state;
    double t_start, t;   /* start time, time of the current state */
    int built;           /* setup succeeded for the current parameters */
    double *v;           /* values by value reference */
    unsigned char *data; /* the model's data */
    double *v_work;      /* scratch copies for steps */
    double call_t, call_h; /* the arguments of the doStep being run */
    fmu_setup_kind_t setup_kind; /* why setup runs (fmu_setup_kind) */
    unsigned char *data_work;
    /* Model Exchange */
    int me;              /* instantiated as Model Exchange */
    int dirty;           /* time, states or inputs changed since the last evaluation */
    double t_accepted;   /* the last accepted time: setTime may not go before it */
    double *z, *z_work;  /* event indicators of the last evaluation */
    /* co-simulation events (FMI 3 event mode): a discrete (Boolean) output changed in the last step */
    int step_event;
    int cs_event_mode;   /* FMI 3 co-simulation: the importer uses event mode */
    int cs_early_return; /* FMI 3 co-simulation: the importer allows early return */
    int returned_early;  /* the last step ended before the master's end, at an event (fi->t) */
    /* messages held back while a step's end is searched (early return): only the messages of
     * the step that is kept reach the host */
    int holding, n_held;
    struct { fmi2Status status; char text[2048]; } held[8];
    char fn_buf[4][64];  /* fmu_fn's names */
    int fn_next;
};

/* "fmi2Reset" / "fmi3Reset": another FMI function's name in this instance's version */
const char *fmu_fn(fmu_instance *fi, const char *suffix);
const char *fmu_state_name(const fmu_instance *fi, int state);
/* 1 when the instance's state is one of `states`, else 0 after logging "fn is not allowed in state X" */
int fmu_allowed(fmu_instance *fi, const char *fn, int states);

/* NULL after logging why (empty name, token not this binary's, out of memory) */
fmu_instance *fmu_instantiate(const char *fn, const char *name, const char *token, int me, int fmi,
                              fmu_emit_fn emit, void *logger, void *env, int logging_on);
void fmu_free_instance(fmu_instance *fi);
fmi2Status fmu_set_debug_logging(fmu_instance *fi, const char *fn, int loggingOn);
fmi2Status fmu_setup_experiment(fmu_instance *fi, const char *fn, double startTime);
fmi2Status fmu_enter_initialization_mode(fmu_instance *fi, const char *fn);
fmi2Status fmu_exit_initialization_mode(fmu_instance *fi, const char *fn);
fmi2Status fmu_terminate(fmu_instance *fi, const char *fn);
fmi2Status fmu_reset(fmu_instance *fi, const char *fn);

/* values as doubles (Integers and Booleans exact) */
fmi2Status fmu_get(fmu_instance *fi, const char *fn, const unsigned int vr[], size_t nvr, fmu_type type, double *out);
fmi2Status fmu_set(fmu_instance *fi, const char *fn, const unsigned int vr[], size_t nvr, fmu_type type,
                   const double *in);

fmi2Status fmu_do_step(fmu_instance *fi, const char *fn, double currentCommunicationPoint,
                       double communicationStepSize);

fmi2Status fmu_get_state(fmu_instance *fi, const char *fn, void **state);
fmi2Status fmu_set_state(fmu_instance *fi, const char *fn, const void *state);
fmi2Status fmu_free_state(fmu_instance *fi, const char *fn, void **state);
fmi2Status fmu_serialized_size(fmu_instance *fi, const char *fn, size_t *size);
fmi2Status fmu_serialize(fmu_instance *fi, const char *fn, const void *state, unsigned char *serializedState,
                         size_t size);
fmi2Status fmu_deserialize(fmu_instance *fi, const char *fn, const unsigned char *serializedState, size_t size,
                           void **state);

fmi2Status fmu_enter_event_mode(fmu_instance *fi, const char *fn);
fmi2Status fmu_enter_step_mode(fmu_instance *fi, const char *fn);
fmi2Status fmu_update_discrete_states(fmu_instance *fi, const char *fn, fmu_event *info);
fmi2Status fmu_enter_continuous_time_mode(fmu_instance *fi, const char *fn);
fmi2Status fmu_completed_integrator_step(fmu_instance *fi, const char *fn, int *enterEventMode,
                                         int *terminateSimulation);
fmi2Status fmu_set_time(fmu_instance *fi, const char *fn, double time);
fmi2Status fmu_set_continuous_states(fmu_instance *fi, const char *fn, const double x[], size_t nx);
fmi2Status fmu_get_continuous_states(fmu_instance *fi, const char *fn, double x[], size_t nx);
fmi2Status fmu_get_derivatives(fmu_instance *fi, const char *fn, double derivatives[], size_t nx);
fmi2Status fmu_get_event_indicators(fmu_instance *fi, const char *fn, double eventIndicators[], size_t ni);
fmi2Status fmu_get_nominals(fmu_instance *fi, const char *fn, double x_nominal[], size_t nx);

#endif
