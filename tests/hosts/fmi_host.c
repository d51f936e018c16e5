/* tests/hosts/fmi_host.c: a minimal co-simulation host in C, for the native FMUs: FMI 2.0, or
 * FMI 3.0 with event mode and early return when compiled with -DFMI_VERSION=3.
 *
 * No Python, no LD_PRELOAD: it dlopens the FMU's binary, and `cycles` times instantiates
 * it, runs `steps` communication steps of `h` seconds from t = 0, reads one Real output,
 * takes an FMU state through its serialised form (a copy with one bit changed must be
 * refused with an error, the intact one is restored), terminates and frees it; then it dlcloses
 * the library and exits. It prints the output's last value and the resident set size (kB) after
 * the first and after the last cycle, so that a test can see leaks as growth; the exit status is
 * 0 only when every call returned OK (or Warning).
 *
 * FMI 3.0: the instance is created with eventModeUsed and earlyReturnAllowed. A step that returns
 * early ends at lastSuccessfulTime; the next one starts there and goes on to the same grid point
 * (the steps' ends stay k h). When a step asks for event handling (eventHandlingNeeded), the host
 * enters event mode, updates the discrete states until no update is needed, and enters step mode;
 * so too after the initialisation (which ends in event mode). A second line lists, for the last
 * cycle, the number of event updates and the times the steps returned early at (FMI 2.0: none):
 *   events <n> early <t1> <t2> ...
 *
 *   fmi_host LIBRARY TOKEN RESOURCES STEPS H CYCLES OUTPUT_VR [I<vr>=<value> | R<vr>=<value> ...]
 *
 * TOKEN is the GUID (FMI 2.0) or instantiation token (FMI 3.0), RESOURCES the resource URI
 * (FMI 2.0) or path (FMI 3.0). The optional settings (an Integer or a Real by value reference)
 * are made after each instantiation, before the initialisation.
 */
#include <dlfcn.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#ifndef FMI_VERSION
#define FMI_VERSION 2
#endif

/* the version's functions the host calls (X-macro; each is called through the pointer <name>_
 * that dlsym gives), its types, and the FMU-state calls under common names (their arguments are
 * the same in both versions) */
#if FMI_VERSION == 3
#include "fmi3Functions.h"
#define FUNCTIONS(X)                                                                                \
    X(fmi3InstantiateCoSimulation) X(fmi3EnterInitializationMode) X(fmi3ExitInitializationMode)    \
    X(fmi3EnterEventMode) X(fmi3UpdateDiscreteStates) X(fmi3EnterStepMode) X(fmi3DoStep)           \
    X(fmi3GetFloat64) X(fmi3SetFloat64) X(fmi3SetInt32) X(fmi3Terminate) X(fmi3FreeInstance)        \
    X(fmi3GetFMUState) X(fmi3SetFMUState) X(fmi3FreeFMUState) X(fmi3SerializedFMUStateSize)        \
    X(fmi3SerializeFMUState) X(fmi3DeserializeFMUState)
typedef fmi3Instance Instance;
typedef fmi3Status Status;
typedef fmi3FMUState FMUState;
typedef fmi3Byte Byte;
typedef fmi3ValueReference VR;
#define OK_OR_WARNING fmi3Warning
#define REFUSED fmi3Error
#define GetState fmi3GetFMUState_
#define SetState fmi3SetFMUState_
#define FreeState fmi3FreeFMUState_
#define StateSize fmi3SerializedFMUStateSize_
#define Serialize fmi3SerializeFMUState_
#define Deserialize fmi3DeserializeFMUState_
#define Terminate fmi3Terminate_
#define FreeInstance fmi3FreeInstance_
#else
#include "fmi2Functions.h"
#define FUNCTIONS(X)                                                                                \
    X(fmi2Instantiate) X(fmi2SetupExperiment) X(fmi2EnterInitializationMode)                       \
    X(fmi2ExitInitializationMode) X(fmi2DoStep) X(fmi2GetReal) X(fmi2SetReal) X(fmi2SetInteger)    \
    X(fmi2Terminate) X(fmi2FreeInstance) X(fmi2GetFMUstate) X(fmi2SetFMUstate) X(fmi2FreeFMUstate) \
    X(fmi2SerializedFMUstateSize) X(fmi2SerializeFMUstate) X(fmi2DeSerializeFMUstate)
typedef fmi2Component Instance;
typedef fmi2Status Status;
typedef fmi2FMUstate FMUState;
typedef fmi2Byte Byte;
typedef fmi2ValueReference VR;
#define OK_OR_WARNING fmi2Warning
#define REFUSED fmi2Error
#define GetState fmi2GetFMUstate_
#define SetState fmi2SetFMUstate_
#define FreeState fmi2FreeFMUstate_
#define StateSize fmi2SerializedFMUstateSize_
#define Serialize fmi2SerializeFMUstate_
#define Deserialize fmi2DeSerializeFMUstate_
#define Terminate fmi2Terminate_
#define FreeInstance fmi2FreeInstance_
#endif

#define DECLARE(name) static name##TYPE *name##_;
FUNCTIONS(DECLARE)

static int failed;
static long n_events; /* event updates (FMI 3.0) */

#define CHECK(call)                                                                    \
    do {                                                                               \
        Status s_ = (call);                                                            \
        if (s_ > OK_OR_WARNING) {                                                      \
            fprintf(stderr, "fmi_host: %s returned %d\n", #call, (int)s_);             \
            failed = 1;                                                                \
        }                                                                              \
    } while (0)

static long rss_kb(void)
{
    FILE *f = fopen("/proc/self/status", "r");
    char line[256];
    long kb = -1;
    if (!f) return -1;
    while (fgets(line, sizeof line, f))
        if (strncmp(line, "VmRSS:", 6) == 0) kb = strtol(line + 6, NULL, 10);
    fclose(f);
    return kb;
}

#if FMI_VERSION == 3
static void logger(fmi3InstanceEnvironment env, fmi3Status status, fmi3String category, fmi3String message)
{
    (void)env;
    fprintf(stderr, "[%d %s] %s\n", (int)status, category, message);
}

static Instance instantiate(const char *token, const char *resources)
{
    return fmi3InstantiateCoSimulation_("host", token, resources, fmi3False, fmi3False, fmi3True, fmi3True, NULL, 0,
                                       NULL, logger, NULL);
}

static Status set_real(Instance inst, VR r, double x) { return fmi3SetFloat64_(inst, &r, 1, &x, 1); }
static Status set_integer(Instance inst, VR r, long x)
{
    fmi3Int32 i = (fmi3Int32)x;
    return fmi3SetInt32_(inst, &r, 1, &i, 1);
}
static Status get_real(Instance inst, VR r, double *x) { return fmi3GetFloat64_(inst, &r, 1, x, 1); }

/* event mode: update the discrete states until no further update is needed, then step mode */
static void handle_event(Instance inst)
{
    fmi3Boolean again = fmi3True, terminate = fmi3False, nominals, values, next_defined;
    fmi3Float64 next;
    for (int round = 0; again && !failed; round++) {
        if (round == 10) {
            fprintf(stderr, "fmi_host: fmi3UpdateDiscreteStates still asks for an update after 10 rounds\n");
            failed = 1;
            return;
        }
        CHECK(fmi3UpdateDiscreteStates_(inst, &again, &terminate, &nominals, &values, &next_defined, &next));
        n_events++;
    }
    if (terminate) {
        fprintf(stderr, "fmi_host: the FMU asked to terminate the simulation\n");
        failed = 1;
    }
    CHECK(fmi3EnterStepMode_(inst));
}

static void initialise(Instance inst)
{
    CHECK(fmi3EnterInitializationMode_(inst, fmi3False, 0.0, 0.0, fmi3False, 0.0));
    CHECK(fmi3ExitInitializationMode_(inst)); /* with event mode: ends in event mode */
    handle_event(inst);
}

/* a step from t by h: 1 when it returned early, at *reached (lastSuccessfulTime); event mode
 * when the FMU asks for it */
static int step(Instance inst, double t, double h, double *reached)
{
    fmi3Boolean event = fmi3False, terminate = fmi3False, early = fmi3False;
    CHECK(fmi3DoStep_(inst, t, h, fmi3True, &event, &terminate, &early, reached));
    if (terminate) {
        fprintf(stderr, "fmi_host: the FMU asked to terminate the simulation at t = %.17g s\n", *reached);
        failed = 1;
    }
    if (event && !failed) {
        CHECK(fmi3EnterEventMode_(inst));
        handle_event(inst);
    }
    return early && !failed;
}
#else
static void logger(fmi2ComponentEnvironment env, fmi2String name, fmi2Status status, fmi2String category,
                   fmi2String message, ...)
{
    va_list ap;
    (void)env;
    fprintf(stderr, "[%s %d %s] ", name, (int)status, category);
    va_start(ap, message);
    vfprintf(stderr, message, ap);
    va_end(ap);
    fputc('\n', stderr);
}

static const fmi2CallbackFunctions callbacks = {logger, calloc, free, NULL, NULL};

static Instance instantiate(const char *guid, const char *resources)
{
    return fmi2Instantiate_("host", fmi2CoSimulation, guid, resources, &callbacks, fmi2False, fmi2False);
}

static Status set_real(Instance inst, VR r, double x) { return fmi2SetReal_(inst, &r, 1, &x); }
static Status set_integer(Instance inst, VR r, long x)
{
    fmi2Integer i = (fmi2Integer)x;
    return fmi2SetInteger_(inst, &r, 1, &i);
}
static Status get_real(Instance inst, VR r, double *x) { return fmi2GetReal_(inst, &r, 1, x); }

static void initialise(Instance inst)
{
    CHECK(fmi2SetupExperiment_(inst, fmi2False, 0.0, 0.0, fmi2False, 0.0));
    CHECK(fmi2EnterInitializationMode_(inst));
    CHECK(fmi2ExitInitializationMode_(inst));
}

static int step(Instance inst, double t, double h, double *reached)
{
    CHECK(fmi2DoStep_(inst, t, h, fmi2True));
    *reached = t + h;
    return 0; /* FMI 2.0 has no early return */
}
#endif

#define MAX_EARLY 16 /* early returns a run may take (each one is an event) */

int main(int argc, char **argv)
{
    if (argc < 8) {
        fprintf(stderr, "usage: fmi_host LIBRARY TOKEN RESOURCES STEPS H CYCLES OUTPUT_VR [I<vr>=<v> | R<vr>=<v> ...]\n");
        return 2;
    }
    long steps = atol(argv[4]), cycles = atol(argv[6]);
    double h = atof(argv[5]);
    VR vr = (VR)atol(argv[7]);
    void *lib = dlopen(argv[1], RTLD_NOW | RTLD_LOCAL);
    if (!lib) {
        fprintf(stderr, "fmi_host: %s\n", dlerror());
        return 2;
    }
#define LOAD(name)                                                                     \
    if (!(name##_ = (name##TYPE *)dlsym(lib, #name))) {                                \
        fprintf(stderr, "fmi_host: %s missing from %s\n", #name, argv[1]);             \
        return 2;                                                                      \
    }
    FUNCTIONS(LOAD)
    long rss_first = -1;
    double value = 0.0, early[MAX_EARLY];
    int n_early = 0;
    for (long c = 0; c < cycles && !failed; c++) {
        Instance inst = instantiate(argv[2], argv[3]);
        if (!inst) {
            fprintf(stderr, "fmi_host: the instantiation returned NULL\n");
            failed = 1;
            break;
        }
        for (int a = 8; a < argc; a++) {
            char kind = argv[a][0], *eq = strchr(argv[a], '=');
            if (!eq || (kind != 'I' && kind != 'R')) {
                fprintf(stderr, "fmi_host: setting %s is not I<vr>=<value> or R<vr>=<value>\n", argv[a]);
                failed = 1;
                break;
            }
            VR r = (VR)atol(argv[a] + 1);
            if (kind == 'I') CHECK(set_integer(inst, r, atol(eq + 1)));
            else CHECK(set_real(inst, r, atof(eq + 1)));
        }
        n_events = n_early = 0;
        initialise(inst);
        /* steps to the grid points k h; after an early return the next step starts where it ended */
        double t = 0.0;
        for (long k = 0; k < steps && !failed;) {
            double end = (double)(k + 1) * h, reached = end;
            if (step(inst, t, t == (double)k * h ? h : end - t, &reached)) {
                if (n_early == MAX_EARLY || !(reached > t && reached < end)) {
                    fprintf(stderr, "fmi_host: early return at t = %.17g s after %d of them (step from %.17g s)\n",
                            reached, n_early, t);
                    failed = 1;
                    break;
                }
                early[n_early++] = reached;
                t = reached;
            } else {
                t = end;
                k++;
            }
        }
        CHECK(get_real(inst, vr, &value));
        FMUState saved = NULL, restored = NULL;
        size_t size = 0;
        CHECK(GetState(inst, &saved));
        CHECK(StateSize(inst, saved, &size));
        Byte *bytes = malloc(size ? size : 1);
        if (bytes) {
            CHECK(Serialize(inst, saved, bytes, size));
            bytes[size / 2] ^= 1;
            if (Deserialize(inst, bytes, size, &restored) != REFUSED) {
                fprintf(stderr, "fmi_host: a serialised state with a changed bit was not refused\n");
                failed = 1;
            }
            bytes[size / 2] ^= 1;
            CHECK(Deserialize(inst, bytes, size, &restored));
            CHECK(SetState(inst, restored));
            CHECK(FreeState(inst, &restored));
            free(bytes);
        } else {
            failed = 1;
        }
        CHECK(FreeState(inst, &saved));
        CHECK(Terminate(inst));
        FreeInstance(inst);
        if (c == 0) rss_first = rss_kb();
    }
    long rss_last = rss_kb();
    dlclose(lib);
    printf("%.17g %ld %ld\n", value, rss_first, rss_last);
    printf("events %ld early", n_events);
    for (int i = 0; i < n_early; i++) printf(" %.17g", early[i]);
    printf("\n");
    return failed;
}
