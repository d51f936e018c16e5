/* fmu_src/native/fmi3.c: FMI 3.0 (co-simulation and Model Exchange) for every native ballmill
 * FMU: the fmi3 functions, translated to the plumbing written once for every FMI version
 * (fmu_instance.c: the state machine, checks, get/set, steps, Model Exchange, FMU states with
 * their format version and checksum, the semantics documented there). FMI 3.0's own parts:
 *   - co-simulation with event mode (hasEventMode): a step in which a discrete (Boolean) output changed
 *     (BallInShell's valid latching, contact, rolling) returns eventHandlingNeeded = true; the
 *     importer enters event mode (nothing to update: the step latched it), then step mode.
 *     Without event mode the step behaves as in FMI 2.0;
 *   - early return (mightReturnEarlyFromDoStep): when the importer allows it
 *     (earlyReturnAllowed), a step that meets an event (a time event of a drive law, a Boolean
 *     output changing) ends there: earlyReturn = true, lastSuccessfulTime = the event's time,
 *     the outputs those at that time (fmu_instance.c's step_to_event); without an event, and for
 *     an importer that does not allow it, the step is FMI 2.0's;
 *   - the types: Float64 (Real), Int32 (Integer), Boolean; no other type has variables;
 *   - what these FMUs do not provide (clocks, configuration mode, directional and adjoint
 *     derivatives, output derivatives, scheduled execution, per-element dependencies): refused
 *     with fmi3Error and a message. */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi3Functions.h"
#include "fmu_instance.h"
#include "fmu_model.h"

#define ST(s) ((fmi3Status)(s)) /* the model API's statuses are FMI 3's, value for value */

static void emit(fmu_instance *fi, fmi2Status status, const char *category, const char *message)
{
    fmi3LogMessageCallback log = (fmi3LogMessageCallback)fi->logger;
    log((fmi3InstanceEnvironment)fi->env, ST(status), category, message);
}

static fmi3Status refuse(fmi3Instance instance, const char *fn, const char *why)
{
    fmu_instance *fi = instance;
    if (fi) fmu_log(fi, fmi2Error, "%s '%s': %s: %s", FMU_MODEL.identifier, fmu_instance_name(fi), fn, why);
    return fmi3Error;
}

const char *fmi3GetVersion(void) { return fmi3Version; }

fmi3Status fmi3SetDebugLogging(fmi3Instance instance, fmi3Boolean loggingOn, size_t nCategories,
                               const fmi3String categories[])
{
    (void)nCategories;
    (void)categories;
    return ST(fmu_set_debug_logging(instance, "fmi3SetDebugLogging", loggingOn));
}

fmi3Instance fmi3InstantiateModelExchange(fmi3String instanceName, fmi3String instantiationToken,
                                          fmi3String resourcePath, fmi3Boolean visible, fmi3Boolean loggingOn,
                                          fmi3InstanceEnvironment instanceEnvironment,
                                          fmi3LogMessageCallback logMessage)
{
    (void)resourcePath;
    (void)visible;
    if (!FMU_MODEL.me) {
        if (logMessage)
            logMessage(instanceEnvironment, fmi3Error, "logStatusError",
                       "fmi3InstantiateModelExchange: this FMU has no Model Exchange");
        return NULL;
    }
    return fmu_instantiate("fmi3InstantiateModelExchange", instanceName, instantiationToken, 1, 3,
                           logMessage ? emit : NULL, (void *)logMessage, instanceEnvironment, loggingOn);
}

fmi3Instance fmi3InstantiateCoSimulation(fmi3String instanceName, fmi3String instantiationToken,
                                         fmi3String resourcePath, fmi3Boolean visible, fmi3Boolean loggingOn,
                                         fmi3Boolean eventModeUsed, fmi3Boolean earlyReturnAllowed,
                                         const fmi3ValueReference requiredIntermediateVariables[],
                                         size_t nRequiredIntermediateVariables,
                                         fmi3InstanceEnvironment instanceEnvironment,
                                         fmi3LogMessageCallback logMessage,
                                         fmi3IntermediateUpdateCallback intermediateUpdate)
{
    (void)resourcePath;
    (void)visible;
    (void)requiredIntermediateVariables;
    (void)nRequiredIntermediateVariables;
    (void)intermediateUpdate; /* providesIntermediateUpdate = false */
    fmu_instance *fi = fmu_instantiate("fmi3InstantiateCoSimulation", instanceName, instantiationToken, 0, 3,
                                       logMessage ? emit : NULL, (void *)logMessage, instanceEnvironment,
                                       loggingOn);
    if (fi) {
        fi->cs_event_mode = eventModeUsed ? 1 : 0;
        fi->cs_early_return = earlyReturnAllowed ? 1 : 0;
    }
    return fi;
}

fmi3Instance fmi3InstantiateScheduledExecution(fmi3String instanceName, fmi3String instantiationToken,
                                               fmi3String resourcePath, fmi3Boolean visible, fmi3Boolean loggingOn,
                                               fmi3InstanceEnvironment instanceEnvironment,
                                               fmi3LogMessageCallback logMessage, fmi3ClockUpdateCallback clockUpdate,
                                               fmi3LockPreemptionCallback lockPreemption,
                                               fmi3UnlockPreemptionCallback unlockPreemption)
{
    (void)instanceName;
    (void)instantiationToken;
    (void)resourcePath;
    (void)visible;
    (void)loggingOn;
    (void)clockUpdate;
    (void)lockPreemption;
    (void)unlockPreemption;
    if (logMessage)
        logMessage(instanceEnvironment, fmi3Error, "logStatusError",
                   "fmi3InstantiateScheduledExecution: this FMU has no scheduled execution");
    return NULL;
}

void fmi3FreeInstance(fmi3Instance instance) { fmu_free_instance(instance); }

fmi3Status fmi3EnterInitializationMode(fmi3Instance instance, fmi3Boolean toleranceDefined, fmi3Float64 tolerance,
                                       fmi3Float64 startTime, fmi3Boolean stopTimeDefined, fmi3Float64 stopTime)
{
    (void)toleranceDefined;
    (void)tolerance;
    (void)stopTimeDefined;
    (void)stopTime;
    fmi2Status s = fmu_setup_experiment(instance, "fmi3EnterInitializationMode", startTime);
    if (s > fmi2Warning) return ST(s);
    return ST(fmu_enter_initialization_mode(instance, "fmi3EnterInitializationMode"));
}

fmi3Status fmi3ExitInitializationMode(fmi3Instance instance)
{
    return ST(fmu_exit_initialization_mode(instance, "fmi3ExitInitializationMode"));
}

fmi3Status fmi3EnterEventMode(fmi3Instance instance) { return ST(fmu_enter_event_mode(instance, "fmi3EnterEventMode")); }
fmi3Status fmi3Terminate(fmi3Instance instance) { return ST(fmu_terminate(instance, "fmi3Terminate")); }
fmi3Status fmi3Reset(fmi3Instance instance) { return ST(fmu_reset(instance, "fmi3Reset")); }

/* ------------------------------------------------------------------ get / set */
#define CHUNK 64
/* the variables of type `type` as doubles, CHUNK at a time (nValues must equal nValueReferences:
 * these FMUs have scalars only) */
#define GETTER(NAME, CTYPE, FTYPE, CONVERT)                                                                  \
    fmi3Status NAME(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, \
                    CTYPE values[], size_t nValues)                                                          \
    {                                                                                                        \
        double buf[CHUNK];                                                                                   \
        if (nValues != nValueReferences) return refuse(instance, #NAME, "nValues must equal nValueReferences " \
                                                       "(every variable is a scalar)");                      \
        for (size_t k = 0; k < nValueReferences || k == 0; k += CHUNK) {                                     \
            size_t n = nValueReferences - k < CHUNK ? nValueReferences - k : CHUNK;                          \
            fmi2Status s = fmu_get(instance, #NAME, valueReferences ? valueReferences + k : NULL, n, FTYPE, buf); \
            if (s != fmi2OK) return ST(s);                                                                   \
            for (size_t i = 0; i < n; i++) values[k + i] = CONVERT;                                          \
            if (nValueReferences == 0) break;                                                                \
        }                                                                                                    \
        return fmi3OK;                                                                                       \
    }
#define SETTER(NAME, CTYPE, FTYPE, CONVERT)                                                                  \
    fmi3Status NAME(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, \
                    const CTYPE values[], size_t nValues)                                                    \
    {                                                                                                        \
        if (nValues != nValueReferences) return refuse(instance, #NAME, "nValues must equal nValueReferences " \
                                                       "(every variable is a scalar)");                      \
        double *buf = malloc((nValueReferences ? nValueReferences : 1) * sizeof(double));                   \
        if (!buf) return fmi3Error;                                                                          \
        for (size_t i = 0; i < nValueReferences; i++) buf[i] = CONVERT;                                      \
        fmi2Status s = fmu_set(instance, #NAME, valueReferences, nValueReferences, FTYPE, buf);             \
        free(buf);                                                                                           \
        return ST(s);                                                                                        \
    }
GETTER(fmi3GetFloat64, fmi3Float64, FMU_REAL, buf[i])
GETTER(fmi3GetInt32, fmi3Int32, FMU_INTEGER, (fmi3Int32)buf[i])
GETTER(fmi3GetBoolean, fmi3Boolean, FMU_BOOLEAN, buf[i] != 0.0)
SETTER(fmi3SetFloat64, fmi3Float64, FMU_REAL, values[i])
SETTER(fmi3SetInt32, fmi3Int32, FMU_INTEGER, (double)values[i])
SETTER(fmi3SetBoolean, fmi3Boolean, FMU_BOOLEAN, values[i] ? 1.0 : 0.0)

/* the types these FMUs have no variables of: nothing to get or set (an empty call is fine) */
#define NONE(NAME, CTYPE, CONST)                                                                             \
    fmi3Status NAME(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, \
                    CONST CTYPE values[], size_t nValues)                                                    \
    {                                                                                                        \
        (void)valueReferences;                                                                               \
        (void)values;                                                                                        \
        (void)nValues;                                                                                       \
        if (!fmu_allowed(instance, #NAME, ANY_STATE)) return fmi3Error;                                      \
        if (nValueReferences == 0) return fmi3OK;                                                            \
        return refuse(instance, #NAME, "this FMU has no variables of this type (Float64, Int32 and Boolean "  \
                      "only)");                                                                              \
    }
NONE(fmi3GetFloat32, fmi3Float32, )
NONE(fmi3GetInt8, fmi3Int8, )
NONE(fmi3GetUInt8, fmi3UInt8, )
NONE(fmi3GetInt16, fmi3Int16, )
NONE(fmi3GetUInt16, fmi3UInt16, )
NONE(fmi3GetUInt32, fmi3UInt32, )
NONE(fmi3GetInt64, fmi3Int64, )
NONE(fmi3GetUInt64, fmi3UInt64, )
NONE(fmi3GetString, fmi3String, )
NONE(fmi3SetFloat32, fmi3Float32, const)
NONE(fmi3SetInt8, fmi3Int8, const)
NONE(fmi3SetUInt8, fmi3UInt8, const)
NONE(fmi3SetInt16, fmi3Int16, const)
NONE(fmi3SetUInt16, fmi3UInt16, const)
NONE(fmi3SetUInt32, fmi3UInt32, const)
NONE(fmi3SetInt64, fmi3Int64, const)
NONE(fmi3SetUInt64, fmi3UInt64, const)
NONE(fmi3SetString, fmi3String, const)

fmi3Status fmi3GetBinary(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                         size_t valueSizes[], fmi3Binary values[], size_t nValues)
{
    (void)valueReferences;
    (void)valueSizes;
    (void)values;
    (void)nValues;
    if (nValueReferences == 0) return fmi3OK;
    return refuse(instance, "fmi3GetBinary", "this FMU has no Binary variables");
}

fmi3Status fmi3SetBinary(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                         const size_t valueSizes[], const fmi3Binary values[], size_t nValues)
{
    (void)valueReferences;
    (void)valueSizes;
    (void)values;
    (void)nValues;
    if (nValueReferences == 0) return fmi3OK;
    return refuse(instance, "fmi3SetBinary", "this FMU has no Binary variables");
}

fmi3Status fmi3GetClock(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                        fmi3Clock values[])
{
    (void)valueReferences;
    (void)values;
    if (nValueReferences == 0) return fmi3OK;
    return refuse(instance, "fmi3GetClock", "this FMU has no clocks");
}

fmi3Status fmi3SetClock(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                        const fmi3Clock values[])
{
    (void)valueReferences;
    (void)values;
    if (nValueReferences == 0) return fmi3OK;
    return refuse(instance, "fmi3SetClock", "this FMU has no clocks");
}

fmi3Status fmi3GetNumberOfVariableDependencies(fmi3Instance instance, fmi3ValueReference valueReference,
                                               size_t *nDependencies)
{
    (void)valueReference;
    (void)nDependencies;
    return refuse(instance, "fmi3GetNumberOfVariableDependencies", "not provided: the dependencies are in the "
                  "model description's ModelStructure");
}

fmi3Status fmi3GetVariableDependencies(fmi3Instance instance, fmi3ValueReference dependent,
                                       size_t elementIndicesOfDependent[], fmi3ValueReference independents[],
                                       size_t elementIndicesOfIndependents[], fmi3DependencyKind dependencyKinds[],
                                       size_t nDependencies)
{
    (void)dependent;
    (void)elementIndicesOfDependent;
    (void)independents;
    (void)elementIndicesOfIndependents;
    (void)dependencyKinds;
    (void)nDependencies;
    return refuse(instance, "fmi3GetVariableDependencies", "not provided: the dependencies are in the model "
                  "description's ModelStructure");
}

/* ------------------------------------------------------------------ FMU states */
fmi3Status fmi3GetFMUState(fmi3Instance instance, fmi3FMUState *FMUState)
{
    return ST(fmu_get_state(instance, "fmi3GetFMUState", FMUState));
}

fmi3Status fmi3SetFMUState(fmi3Instance instance, fmi3FMUState FMUState)
{
    return ST(fmu_set_state(instance, "fmi3SetFMUState", FMUState));
}

fmi3Status fmi3FreeFMUState(fmi3Instance instance, fmi3FMUState *FMUState)
{
    return ST(fmu_free_state(instance, "fmi3FreeFMUState", FMUState));
}

fmi3Status fmi3SerializedFMUStateSize(fmi3Instance instance, fmi3FMUState FMUState, size_t *size)
{
    (void)FMUState;
    return ST(fmu_serialized_size(instance, "fmi3SerializedFMUStateSize", size));
}

fmi3Status fmi3SerializeFMUState(fmi3Instance instance, fmi3FMUState FMUState, fmi3Byte serializedState[],
                                 size_t size)
{
    return ST(fmu_serialize(instance, "fmi3SerializeFMUState", FMUState, serializedState, size));
}

fmi3Status fmi3DeserializeFMUState(fmi3Instance instance, const fmi3Byte serializedState[], size_t size,
                                   fmi3FMUState *FMUState)
{
    return ST(fmu_deserialize(instance, "fmi3DeserializeFMUState", serializedState, size, FMUState));
}

/* ------------------------------------------------------------------ not provided */
fmi3Status fmi3GetDirectionalDerivative(fmi3Instance instance, const fmi3ValueReference unknowns[], size_t nUnknowns,
                                        const fmi3ValueReference knowns[], size_t nKnowns, const fmi3Float64 seed[],
                                        size_t nSeed, fmi3Float64 sensitivity[], size_t nSensitivity)
{
    (void)unknowns;
    (void)nUnknowns;
    (void)knowns;
    (void)nKnowns;
    (void)seed;
    (void)nSeed;
    (void)sensitivity;
    (void)nSensitivity;
    return refuse(instance, "fmi3GetDirectionalDerivative", "not supported (providesDirectionalDerivatives = false)");
}

fmi3Status fmi3GetAdjointDerivative(fmi3Instance instance, const fmi3ValueReference unknowns[], size_t nUnknowns,
                                    const fmi3ValueReference knowns[], size_t nKnowns, const fmi3Float64 seed[],
                                    size_t nSeed, fmi3Float64 sensitivity[], size_t nSensitivity)
{
    (void)unknowns;
    (void)nUnknowns;
    (void)knowns;
    (void)nKnowns;
    (void)seed;
    (void)nSeed;
    (void)sensitivity;
    (void)nSensitivity;
    return refuse(instance, "fmi3GetAdjointDerivative", "not supported (providesAdjointDerivatives = false)");
}

fmi3Status fmi3EnterConfigurationMode(fmi3Instance instance)
{
    return refuse(instance, "fmi3EnterConfigurationMode", "this FMU has no structural parameters");
}

fmi3Status fmi3ExitConfigurationMode(fmi3Instance instance)
{
    return refuse(instance, "fmi3ExitConfigurationMode", "this FMU has no structural parameters");
}

fmi3Status fmi3GetIntervalDecimal(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                  size_t nValueReferences, fmi3Float64 intervals[], fmi3IntervalQualifier qualifiers[])
{
    (void)valueReferences;
    (void)intervals;
    (void)qualifiers;
    if (nValueReferences == 0) return fmi3OK;
    return refuse(instance, "fmi3GetIntervalDecimal", "this FMU has no clocks");
}

fmi3Status fmi3GetIntervalFraction(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                   size_t nValueReferences, fmi3UInt64 counters[], fmi3UInt64 resolutions[],
                                   fmi3IntervalQualifier qualifiers[])
{
    (void)valueReferences;
    (void)counters;
    (void)resolutions;
    (void)qualifiers;
    if (nValueReferences == 0) return fmi3OK;
    return refuse(instance, "fmi3GetIntervalFraction", "this FMU has no clocks");
}

fmi3Status fmi3GetShiftDecimal(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                               size_t nValueReferences, fmi3Float64 shifts[])
{
    (void)valueReferences;
    (void)shifts;
    if (nValueReferences == 0) return fmi3OK;
    return refuse(instance, "fmi3GetShiftDecimal", "this FMU has no clocks");
}

fmi3Status fmi3GetShiftFraction(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                size_t nValueReferences, fmi3UInt64 counters[], fmi3UInt64 resolutions[])
{
    (void)valueReferences;
    (void)counters;
    (void)resolutions;
    if (nValueReferences == 0) return fmi3OK;
    return refuse(instance, "fmi3GetShiftFraction", "this FMU has no clocks");
}

fmi3Status fmi3SetIntervalDecimal(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                  size_t nValueReferences, const fmi3Float64 intervals[])
{
    (void)valueReferences;
    (void)intervals;
    if (nValueReferences == 0) return fmi3OK;
    return refuse(instance, "fmi3SetIntervalDecimal", "this FMU has no clocks");
}

fmi3Status fmi3SetIntervalFraction(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                   size_t nValueReferences, const fmi3UInt64 counters[],
                                   const fmi3UInt64 resolutions[])
{
    (void)valueReferences;
    (void)counters;
    (void)resolutions;
    if (nValueReferences == 0) return fmi3OK;
    return refuse(instance, "fmi3SetIntervalFraction", "this FMU has no clocks");
}

fmi3Status fmi3SetShiftDecimal(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                               size_t nValueReferences, const fmi3Float64 shifts[])
{
    (void)valueReferences;
    (void)shifts;
    if (nValueReferences == 0) return fmi3OK;
    return refuse(instance, "fmi3SetShiftDecimal", "this FMU has no clocks");
}

fmi3Status fmi3SetShiftFraction(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                size_t nValueReferences, const fmi3UInt64 counters[],
                                const fmi3UInt64 resolutions[])
{
    (void)valueReferences;
    (void)counters;
    (void)resolutions;
    if (nValueReferences == 0) return fmi3OK;
    return refuse(instance, "fmi3SetShiftFraction", "this FMU has no clocks");
}

fmi3Status fmi3EvaluateDiscreteStates(fmi3Instance instance)
{
    return fmu_allowed(instance, "fmi3EvaluateDiscreteStates", S_INIT | S_EVENT | S_STEP_COMPLETE | S_CONT)
               ? fmi3OK : fmi3Error; /* no clocked partitions: nothing to evaluate */
}

fmi3Status fmi3UpdateDiscreteStates(fmi3Instance instance, fmi3Boolean *discreteStatesNeedUpdate,
                                    fmi3Boolean *terminateSimulation, fmi3Boolean *nominalsOfContinuousStatesChanged,
                                    fmi3Boolean *valuesOfContinuousStatesChanged, fmi3Boolean *nextEventTimeDefined,
                                    fmi3Float64 *nextEventTime)
{
    fmu_event ev;
    fmi2Status s = fmu_update_discrete_states(instance, "fmi3UpdateDiscreteStates", &ev);
    if (s > fmi2Warning) return ST(s);
    if (discreteStatesNeedUpdate) *discreteStatesNeedUpdate = fmi3False; /* one update settles every event */
    if (terminateSimulation) *terminateSimulation = ev.terminate ? fmi3True : fmi3False;
    if (nominalsOfContinuousStatesChanged) *nominalsOfContinuousStatesChanged = fmi3False;
    if (valuesOfContinuousStatesChanged) *valuesOfContinuousStatesChanged = ev.states_changed ? fmi3True : fmi3False;
    if (nextEventTimeDefined) *nextEventTimeDefined = ev.next_time_defined ? fmi3True : fmi3False;
    if (nextEventTime) *nextEventTime = ev.next_time_defined ? ev.next_time : 0.0;
    return ST(s);
}

/* ------------------------------------------------------------------ Model Exchange */
fmi3Status fmi3EnterContinuousTimeMode(fmi3Instance instance)
{
    return ST(fmu_enter_continuous_time_mode(instance, "fmi3EnterContinuousTimeMode"));
}

fmi3Status fmi3CompletedIntegratorStep(fmi3Instance instance, fmi3Boolean noSetFMUStatePriorToCurrentPoint,
                                       fmi3Boolean *enterEventMode, fmi3Boolean *terminateSimulation)
{
    int enter = 0, stop = 0;
    (void)noSetFMUStatePriorToCurrentPoint;
    fmi2Status s = fmu_completed_integrator_step(instance, "fmi3CompletedIntegratorStep", &enter, &stop);
    if (enterEventMode) *enterEventMode = enter ? fmi3True : fmi3False;
    if (terminateSimulation) *terminateSimulation = stop ? fmi3True : fmi3False;
    return ST(s);
}

fmi3Status fmi3SetTime(fmi3Instance instance, fmi3Float64 time) { return ST(fmu_set_time(instance, "fmi3SetTime", time)); }

fmi3Status fmi3SetContinuousStates(fmi3Instance instance, const fmi3Float64 continuousStates[],
                                   size_t nContinuousStates)
{
    return ST(fmu_set_continuous_states(instance, "fmi3SetContinuousStates", continuousStates, nContinuousStates));
}

fmi3Status fmi3GetContinuousStateDerivatives(fmi3Instance instance, fmi3Float64 derivatives[],
                                             size_t nContinuousStates)
{
    return ST(fmu_get_derivatives(instance, "fmi3GetContinuousStateDerivatives", derivatives, nContinuousStates));
}

fmi3Status fmi3GetEventIndicators(fmi3Instance instance, fmi3Float64 eventIndicators[], size_t nEventIndicators)
{
    return ST(fmu_get_event_indicators(instance, "fmi3GetEventIndicators", eventIndicators, nEventIndicators));
}

fmi3Status fmi3GetContinuousStates(fmi3Instance instance, fmi3Float64 continuousStates[], size_t nContinuousStates)
{
    return ST(fmu_get_continuous_states(instance, "fmi3GetContinuousStates", continuousStates, nContinuousStates));
}

fmi3Status fmi3GetNominalsOfContinuousStates(fmi3Instance instance, fmi3Float64 nominals[], size_t nContinuousStates)
{
    return ST(fmu_get_nominals(instance, "fmi3GetNominalsOfContinuousStates", nominals, nContinuousStates));
}

fmi3Status fmi3GetNumberOfEventIndicators(fmi3Instance instance, size_t *nEventIndicators)
{
    if (!fmu_allowed(instance, "fmi3GetNumberOfEventIndicators", ANY_STATE) || !nEventIndicators) return fmi3Error;
    *nEventIndicators = FMU_MODEL.me ? (size_t)FMU_MODEL.me->n_indicators : 0;
    return fmi3OK;
}

fmi3Status fmi3GetNumberOfContinuousStates(fmi3Instance instance, size_t *nContinuousStates)
{
    if (!fmu_allowed(instance, "fmi3GetNumberOfContinuousStates", ANY_STATE) || !nContinuousStates) return fmi3Error;
    *nContinuousStates = FMU_MODEL.me ? (size_t)FMU_MODEL.me->n_states : 0;
    return fmi3OK;
}

/* ------------------------------------------------------------------ co-simulation */
fmi3Status fmi3EnterStepMode(fmi3Instance instance) { return ST(fmu_enter_step_mode(instance, "fmi3EnterStepMode")); }

fmi3Status fmi3GetOutputDerivatives(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                    size_t nValueReferences, const fmi3Int32 orders[], fmi3Float64 values[],
                                    size_t nValues)
{
    (void)valueReferences;
    (void)nValueReferences;
    (void)orders;
    (void)values;
    (void)nValues;
    return refuse(instance, "fmi3GetOutputDerivatives", "not supported (maxOutputDerivativeOrder = 0)");
}

fmi3Status fmi3DoStep(fmi3Instance instance, fmi3Float64 currentCommunicationPoint,
                      fmi3Float64 communicationStepSize, fmi3Boolean noSetFMUStatePriorToCurrentPoint,
                      fmi3Boolean *eventHandlingNeeded, fmi3Boolean *terminateSimulation, fmi3Boolean *earlyReturn,
                      fmi3Float64 *lastSuccessfulTime)
{
    fmu_instance *fi = instance;
    (void)noSetFMUStatePriorToCurrentPoint;
    fmi2Status s = fmu_do_step(fi, "fmi3DoStep", currentCommunicationPoint, communicationStepSize);
    if (eventHandlingNeeded) *eventHandlingNeeded = fi && s <= fmi2Warning && fi->cs_event_mode && fi->step_event;
    if (terminateSimulation) *terminateSimulation = fmi3False;
    if (earlyReturn) *earlyReturn = fi && s <= fmi2Warning && fi->returned_early;
    if (lastSuccessfulTime && fi) *lastSuccessfulTime = fi->t;
    return ST(s);
}

fmi3Status fmi3ActivateModelPartition(fmi3Instance instance, fmi3ValueReference clockReference,
                                      fmi3Float64 activationTime)
{
    (void)clockReference;
    (void)activationTime;
    return refuse(instance, "fmi3ActivateModelPartition", "this FMU has no scheduled execution");
}
