/* tests/hosts/fmi_host.c: a minimal FMI 2.0 co-simulation host in C, for the native FMUs.
 *
 * No Python, no LD_PRELOAD: it dlopens the FMU's binary, and `cycles` times instantiates
 * it, runs `steps` communication steps of `h` seconds from t = 0, reads one Real output,
 * takes an FMU state through its serialised form (a copy with one bit changed must be
 * refused with fmi2Error, the intact one is restored), terminates and frees it; then it dlcloses the library and exits. It prints the output's
 * last value and the resident set size (kB) after the first and after the last cycle, so
 * that a test can see leaks as growth; the exit status is 0 only when every call
 * returned fmi2OK (or fmi2Warning).
 *
 *   fmi_host LIBRARY GUID RESOURCE_URI STEPS H CYCLES OUTPUT_VR [I<vr>=<value> | R<vr>=<value> ...]
 *
 * The optional settings (an Integer or a Real by value reference) are made after each
 * fmi2Instantiate, before the initialisation.
 */
#include <dlfcn.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi2Functions.h"

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

#define LOAD(name)                                                                     \
    name##TYPE *name = (name##TYPE *)dlsym(lib, #name);                                \
    if (!name) {                                                                       \
        fprintf(stderr, "fmi_host: %s missing from %s\n", #name, argv[1]);             \
        return 2;                                                                      \
    }

#define CHECK(call)                                                                    \
    do {                                                                               \
        fmi2Status s_ = (call);                                                        \
        if (s_ > fmi2Warning) {                                                        \
            fprintf(stderr, "fmi_host: %s returned %d\n", #call, (int)s_);             \
            failed = 1;                                                                \
        }                                                                              \
    } while (0)

int main(int argc, char **argv)
{
    if (argc < 8) {
        fprintf(stderr, "usage: fmi_host LIBRARY GUID RESOURCE_URI STEPS H CYCLES OUTPUT_VR [I<vr>=<v> | R<vr>=<v> ...]\n");
        return 2;
    }
    long steps = atol(argv[4]), cycles = atol(argv[6]);
    double h = atof(argv[5]);
    fmi2ValueReference vr = (fmi2ValueReference)atol(argv[7]);
    void *lib = dlopen(argv[1], RTLD_NOW | RTLD_LOCAL);
    if (!lib) {
        fprintf(stderr, "fmi_host: %s\n", dlerror());
        return 2;
    }
    LOAD(fmi2Instantiate)
    LOAD(fmi2SetupExperiment)
    LOAD(fmi2EnterInitializationMode)
    LOAD(fmi2ExitInitializationMode)
    LOAD(fmi2DoStep)
    LOAD(fmi2GetReal)
    LOAD(fmi2SetReal)
    LOAD(fmi2SetInteger)
    LOAD(fmi2Terminate)
    LOAD(fmi2FreeInstance)
    LOAD(fmi2GetFMUstate)
    LOAD(fmi2SetFMUstate)
    LOAD(fmi2FreeFMUstate)
    LOAD(fmi2SerializedFMUstateSize)
    LOAD(fmi2SerializeFMUstate)
    LOAD(fmi2DeSerializeFMUstate)
    fmi2CallbackFunctions cb = {logger, calloc, free, NULL, NULL};
    int failed = 0;
    long rss_first = -1;
    double value = 0.0;
    for (long c = 0; c < cycles && !failed; c++) {
        fmi2Component inst = fmi2Instantiate("host", fmi2CoSimulation, argv[2], argv[3], &cb, fmi2False, fmi2False);
        if (!inst) {
            fprintf(stderr, "fmi_host: fmi2Instantiate returned NULL\n");
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
            fmi2ValueReference r = (fmi2ValueReference)atol(argv[a] + 1);
            if (kind == 'I') {
                fmi2Integer x = (fmi2Integer)atol(eq + 1);
                CHECK(fmi2SetInteger(inst, &r, 1, &x));
            } else {
                fmi2Real x = atof(eq + 1);
                CHECK(fmi2SetReal(inst, &r, 1, &x));
            }
        }
        CHECK(fmi2SetupExperiment(inst, fmi2False, 0.0, 0.0, fmi2False, 0.0));
        CHECK(fmi2EnterInitializationMode(inst));
        CHECK(fmi2ExitInitializationMode(inst));
        for (long k = 0; k < steps && !failed; k++) CHECK(fmi2DoStep(inst, (double)k * h, h, fmi2True));
        CHECK(fmi2GetReal(inst, &vr, 1, &value));
        fmi2FMUstate saved = NULL, restored = NULL;
        size_t size = 0;
        CHECK(fmi2GetFMUstate(inst, &saved));
        CHECK(fmi2SerializedFMUstateSize(inst, saved, &size));
        fmi2Byte *bytes = malloc(size ? size : 1);
        if (bytes) {
            CHECK(fmi2SerializeFMUstate(inst, saved, bytes, size));
            bytes[size / 2] ^= 1;
            if (fmi2DeSerializeFMUstate(inst, bytes, size, &restored) != fmi2Error) {
                fprintf(stderr, "fmi_host: a serialised state with a changed bit was not refused\n");
                failed = 1;
            }
            bytes[size / 2] ^= 1;
            CHECK(fmi2DeSerializeFMUstate(inst, bytes, size, &restored));
            CHECK(fmi2SetFMUstate(inst, restored));
            CHECK(fmi2FreeFMUstate(inst, &restored));
            free(bytes);
        } else {
            failed = 1;
        }
        CHECK(fmi2FreeFMUstate(inst, &saved));
        CHECK(fmi2Terminate(inst));
        fmi2FreeInstance(inst);
        if (c == 0) rss_first = rss_kb();
    }
    long rss_last = rss_kb();
    dlclose(lib);
    printf("%.17g %ld %ld\n", value, rss_first, rss_last);
    return failed;
}
