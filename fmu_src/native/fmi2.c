/* fmu_src/native/fmi2.c: FMI 2.0 (co-simulation and Model Exchange) for every native ballmill
 * FMU: the fmi2 functions, translated to the plumbing written once for every FMI version
 * (fmu_instance.c: the state machine, checks, get/set, steps, Model Exchange, FMU states, with
 * the semantics documented there) and FMI 2.0's own calls (the status queries, the functions
 * these FMUs do not provide, refused with a message). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmu_instance.h"
#include "fmu_model.h"

static void emit(fmu_instance *fi, fmi2Status status, const char *category, const char *message)
{
    fmi2CallbackLogger logger = (fmi2CallbackLogger)fi->logger;
    logger((fmi2ComponentEnvironment)fi->env, fi->name, status, category, message);
}

const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }
const char *fmi2GetVersion(void) { return fmi2Version; }

fmi2Component fmi2Instantiate(fmi2String instanceName, fmi2Type fmuType, fmi2String fmuGUID,
                              fmi2String fmuResourceLocation, const fmi2CallbackFunctions *functions,
                              fmi2Boolean visible, fmi2Boolean loggingOn)
{
    (void)fmuResourceLocation;
    (void)visible;
    void *logger = functions && functions->logger ? (void *)functions->logger : NULL;
    void *env = functions ? functions->componentEnvironment : NULL;
    if (fmuType != fmi2CoSimulation && !(fmuType == fmi2ModelExchange && FMU_MODEL.me)) {
        if (logger)
            functions->logger(env, instanceName ? instanceName : "?", fmi2Error, "logStatusError",
                              "fmi2Instantiate: fmuType refused: this FMU supports fmi2ModelExchange (0) and "
                              "fmi2CoSimulation (1)");
        return NULL;
    }
    return fmu_instantiate("fmi2Instantiate", instanceName, fmuGUID, fmuType == fmi2ModelExchange, 2,
                           logger ? emit : NULL, logger, env, loggingOn);
}

void fmi2FreeInstance(fmi2Component c) { fmu_free_instance(c); }

fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean loggingOn, size_t nCategories,
                               const fmi2String categories[])
{
    (void)nCategories;
    (void)categories;
    return fmu_set_debug_logging(c, "fmi2SetDebugLogging", loggingOn);
}

fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean toleranceDefined, fmi2Real tolerance,
                               fmi2Real startTime, fmi2Boolean stopTimeDefined, fmi2Real stopTime)
{
    (void)toleranceDefined;
    (void)tolerance;
    (void)stopTimeDefined;
    (void)stopTime;
    return fmu_setup_experiment(c, "fmi2SetupExperiment", startTime);
}

fmi2Status fmi2EnterInitializationMode(fmi2Component c)
{
    return fmu_enter_initialization_mode(c, "fmi2EnterInitializationMode");
}

fmi2Status fmi2ExitInitializationMode(fmi2Component c)
{
    return fmu_exit_initialization_mode(c, "fmi2ExitInitializationMode");
}

fmi2Status fmi2Terminate(fmi2Component c) { return fmu_terminate(c, "fmi2Terminate"); }
fmi2Status fmi2Reset(fmi2Component c) { return fmu_reset(c, "fmi2Reset"); }

/* ------------------------------------------------------------------ get / set */
fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Real value[])
{
    return fmu_get(c, "fmi2GetReal", vr, nvr, FMU_REAL, value);
}

#define CHUNK 64
fmi2Status fmi2GetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Integer value[])
{
    double buf[CHUNK];
    for (size_t k = 0; k < nvr || k == 0; k += CHUNK) {
        size_t n = nvr - k < CHUNK ? nvr - k : CHUNK;
        fmi2Status s = fmu_get(c, "fmi2GetInteger", vr ? vr + k : NULL, n, FMU_INTEGER, buf);
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
        fmi2Status s = fmu_get(c, "fmi2GetBoolean", vr ? vr + k : NULL, n, FMU_BOOLEAN, buf);
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
    if (!fmu_allowed(fi, "fmi2GetString", READABLE)) return fmi2Error;
    if (nvr == 0) return fmi2OK;
    fmu_log(fi, fmi2Error, "%s '%s': fmi2GetString: this FMU has no String variables", FMU_MODEL.identifier,
            fi->name);
    return fmi2Error;
}

fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Real value[])
{
    return fmu_set(c, "fmi2SetReal", vr, nvr, FMU_REAL, value);
}

fmi2Status fmi2SetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Integer value[])
{
    fmu_instance *fi = c;
    double *buf = malloc((nvr ? nvr : 1) * sizeof(double));
    if (!buf) return fmi2Error;
    for (size_t i = 0; i < nvr; i++) buf[i] = (double)value[i];
    fmi2Status s = fmu_set(fi, "fmi2SetInteger", vr, nvr, FMU_INTEGER, buf);
    free(buf);
    return s;
}

fmi2Status fmi2SetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Boolean value[])
{
    fmu_instance *fi = c;
    double *buf = malloc((nvr ? nvr : 1) * sizeof(double));
    if (!buf) return fmi2Error;
    for (size_t i = 0; i < nvr; i++) buf[i] = value[i] ? 1.0 : 0.0;
    fmi2Status s = fmu_set(fi, "fmi2SetBoolean", vr, nvr, FMU_BOOLEAN, buf);
    free(buf);
    return s;
}

fmi2Status fmi2SetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2String value[])
{
    fmu_instance *fi = c;
    (void)vr;
    (void)value;
    if (!fmu_allowed(fi, "fmi2SetString", S_INSTANTIATED | S_INIT | S_STEP_COMPLETE)) return fmi2Error;
    if (nvr == 0) return fmi2OK;
    fmu_log(fi, fmi2Error, "%s '%s': fmi2SetString: this FMU has no String variables", FMU_MODEL.identifier,
            fi->name);
    return fmi2Error;
}

/* ------------------------------------------------------------------ stepping */
fmi2Status fmi2DoStep(fmi2Component c, fmi2Real currentCommunicationPoint, fmi2Real communicationStepSize,
                      fmi2Boolean noSetFMUStatePriorToCurrentPoint)
{
    (void)noSetFMUStatePriorToCurrentPoint;
    return fmu_do_step(c, "fmi2DoStep", currentCommunicationPoint, communicationStepSize);
}

fmi2Status fmi2CancelStep(fmi2Component c)
{
    fmu_instance *fi = c;
    if (fi) fmu_log(fi, fmi2Error, "%s '%s': fmi2CancelStep is not allowed in state %s (steps are synchronous)",
                    FMU_MODEL.identifier, fi->name, fmu_state_name(fi, fi->state));
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
    if (!fmu_allowed(fi, "fmi2GetStatus", S_STEP_COMPLETE | S_STEP_FAILED | S_TERMINATED)) return fmi2Error;
    if (s != fmi2DoStepStatus || !value) return fmi2Discard;
    *value = fmi2OK; /* steps are synchronous: never pending */
    return fmi2OK;
}

fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind s, fmi2Real *value)
{
    fmu_instance *fi = c;
    if (!fmu_allowed(fi, "fmi2GetRealStatus", S_STEP_COMPLETE | S_STEP_FAILED | S_TERMINATED)) return fmi2Error;
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
    if (!fmu_allowed(fi, "fmi2GetBooleanStatus", S_STEP_COMPLETE | S_STEP_FAILED | S_TERMINATED)) return fmi2Error;
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
fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate *state)
{
    return fmu_get_state(c, "fmi2GetFMUstate", state);
}

fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate state)
{
    return fmu_set_state(c, "fmi2SetFMUstate", state);
}

fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate *state)
{
    return fmu_free_state(c, "fmi2FreeFMUstate", state);
}

fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate state, size_t *size)
{
    (void)state;
    return fmu_serialized_size(c, "fmi2SerializedFMUstateSize", size);
}

fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate state, fmi2Byte serializedState[], size_t size)
{
    return fmu_serialize(c, "fmi2SerializeFMUstate", state, (unsigned char *)serializedState, size);
}

fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte serializedState[], size_t size,
                                   fmi2FMUstate *state)
{
    return fmu_deserialize(c, "fmi2DeSerializeFMUstate", (const unsigned char *)serializedState, size, state);
}

/* ------------------------------------------------------------------ Model Exchange */
fmi2Status fmi2EnterEventMode(fmi2Component c) { return fmu_enter_event_mode(c, "fmi2EnterEventMode"); }

fmi2Status fmi2NewDiscreteStates(fmi2Component c, fmi2EventInfo *info)
{
    fmu_event ev;
    if (!info) return fmi2Error;
    fmi2Status s = fmu_update_discrete_states(c, "fmi2NewDiscreteStates", &ev);
    if (s > fmi2Warning) return s;
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
    return fmu_enter_continuous_time_mode(c, "fmi2EnterContinuousTimeMode");
}

fmi2Status fmi2CompletedIntegratorStep(fmi2Component c, fmi2Boolean noSetFMUStatePriorToCurrentPoint,
                                       fmi2Boolean *enterEventMode, fmi2Boolean *terminateSimulation)
{
    int enter = 0, stop = 0;
    (void)noSetFMUStatePriorToCurrentPoint;
    fmi2Status s = fmu_completed_integrator_step(c, "fmi2CompletedIntegratorStep", &enter, &stop);
    if (enterEventMode) *enterEventMode = enter ? fmi2True : fmi2False;
    if (terminateSimulation) *terminateSimulation = stop ? fmi2True : fmi2False;
    return s;
}

fmi2Status fmi2SetTime(fmi2Component c, fmi2Real time) { return fmu_set_time(c, "fmi2SetTime", time); }

fmi2Status fmi2SetContinuousStates(fmi2Component c, const fmi2Real x[], size_t nx)
{
    return fmu_set_continuous_states(c, "fmi2SetContinuousStates", x, nx);
}

fmi2Status fmi2GetContinuousStates(fmi2Component c, fmi2Real x[], size_t nx)
{
    return fmu_get_continuous_states(c, "fmi2GetContinuousStates", x, nx);
}

fmi2Status fmi2GetDerivatives(fmi2Component c, fmi2Real derivatives[], size_t nx)
{
    return fmu_get_derivatives(c, "fmi2GetDerivatives", derivatives, nx);
}

fmi2Status fmi2GetEventIndicators(fmi2Component c, fmi2Real eventIndicators[], size_t ni)
{
    return fmu_get_event_indicators(c, "fmi2GetEventIndicators", eventIndicators, ni);
}

fmi2Status fmi2GetNominalsOfContinuousStates(fmi2Component c, fmi2Real x_nominal[], size_t nx)
{
    return fmu_get_nominals(c, "fmi2GetNominalsOfContinuousStates", x_nominal, nx);
}
