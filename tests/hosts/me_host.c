/* tests/hosts/me_host.c: a native FMU's FMI 2.0 Model Exchange in a C host, for valgrind
 * (tests/test_native_hosts.py). Usage:
 *     me_host BINARY GUID CYCLES NX NZ VR_VALID [VR VALUE]...
 * Each cycle: instantiate for Model Exchange, set the given Real parameters, initialise, and
 * integrate with explicit Euler (h = 1e-4 s, 3000 steps) through setTime/setContinuousStates/
 * getDerivatives/getEventIndicators, entering event mode where an indicator changed sign; then
 * get, serialise, deserialise and restore an FMU state, check that a state with a byte changed
 * and a NaN continuous state are refused, terminate and free. Prints "valid V" (the Boolean
 * output at VR_VALID after the last cycle) and "ok"; "REFUSAL MISSING: ..." when a bad call
 * was accepted. */
#include <dlfcn.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include "fmi2Functions.h"

static void logger(fmi2ComponentEnvironment env, fmi2String name, fmi2Status status, fmi2String category,
                   fmi2String message, ...)
{
    (void)env;
    (void)name;
    (void)status;
    (void)category;
    (void)message;
}

#define LOAD(name) name##TYPE *name = (name##TYPE *)dlsym(lib, #name)
#define MAXN 32

int main(int argc, char **argv)
{
    if (argc < 7) {
        fprintf(stderr, "usage: me_host BINARY GUID CYCLES NX NZ VR_VALID [VR VALUE]...\n");
        return 2;
    }
    void *lib = dlopen(argv[1], RTLD_NOW);
    if (!lib) {
        fprintf(stderr, "%s\n", dlerror());
        return 2;
    }
    LOAD(fmi2Instantiate); LOAD(fmi2FreeInstance); LOAD(fmi2SetupExperiment); LOAD(fmi2EnterInitializationMode);
    LOAD(fmi2ExitInitializationMode); LOAD(fmi2NewDiscreteStates); LOAD(fmi2EnterContinuousTimeMode);
    LOAD(fmi2SetTime); LOAD(fmi2SetContinuousStates); LOAD(fmi2GetContinuousStates); LOAD(fmi2GetDerivatives);
    LOAD(fmi2GetEventIndicators); LOAD(fmi2CompletedIntegratorStep); LOAD(fmi2EnterEventMode);
    LOAD(fmi2GetFMUstate); LOAD(fmi2SetFMUstate); LOAD(fmi2FreeFMUstate); LOAD(fmi2SerializedFMUstateSize);
    LOAD(fmi2SerializeFMUstate); LOAD(fmi2DeSerializeFMUstate); LOAD(fmi2Terminate); LOAD(fmi2SetReal);
    LOAD(fmi2GetBoolean);
    int cycles = atoi(argv[3]), nx = atoi(argv[4]), nz = atoi(argv[5]);
    fmi2ValueReference vr_valid = (fmi2ValueReference)atoi(argv[6]);
    if (nx < 1 || nx > MAXN || nz < 0 || nz > MAXN) return 2;
    fmi2CallbackFunctions cb = {logger, calloc, free, NULL, NULL};
    fmi2Boolean valid = fmi2True;
    int bad = 0;
    for (int cycle = 0; cycle < cycles; cycle++) {
        fmi2Component c = fmi2Instantiate("me_host", fmi2ModelExchange, argv[2], "", &cb, fmi2False, fmi2False);
        if (!c) return 3;
        for (int a = 7; a + 1 < argc; a += 2) {
            fmi2ValueReference vr = (fmi2ValueReference)atoi(argv[a]);
            double value = atof(argv[a + 1]);
            if (fmi2SetReal(c, &vr, 1, &value) != fmi2OK) return 4;
        }
        fmi2EventInfo ev;
        if (fmi2SetupExperiment(c, fmi2False, 0.0, 0.0, fmi2False, 0.0) != fmi2OK ||
            fmi2EnterInitializationMode(c) != fmi2OK || fmi2ExitInitializationMode(c) > fmi2Warning ||
            fmi2NewDiscreteStates(c, &ev) > fmi2Warning || fmi2EnterContinuousTimeMode(c) != fmi2OK)
            return 5;
        double x[MAXN], dx[MAXN], z[MAXN], z_old[MAXN], t = 0.0, h = 1e-4;
        fmi2Boolean enter, stop;
        if (fmi2GetContinuousStates(c, x, (size_t)nx) != fmi2OK || fmi2GetEventIndicators(c, z_old, (size_t)nz) != fmi2OK)
            return 6;
        for (int i = 0; i < 3000; i++) {
            if (fmi2GetDerivatives(c, dx, (size_t)nx) != fmi2OK) return 7;
            for (int k = 0; k < nx; k++) x[k] += h * dx[k];
            t += h;
            if (fmi2SetTime(c, t) != fmi2OK || fmi2SetContinuousStates(c, x, (size_t)nx) != fmi2OK ||
                fmi2GetEventIndicators(c, z, (size_t)nz) != fmi2OK ||
                fmi2CompletedIntegratorStep(c, fmi2True, &enter, &stop) != fmi2OK)
                return 8;
            int crossed = 0;
            for (int k = 0; k < nz; k++) {
                crossed |= (z[k] < 0.0) != (z_old[k] < 0.0);
                z_old[k] = z[k];
            }
            if (crossed && (fmi2EnterEventMode(c) != fmi2OK || fmi2NewDiscreteStates(c, &ev) > fmi2Warning ||
                            fmi2EnterContinuousTimeMode(c) != fmi2OK))
                return 9;
        }
        if (fmi2SetTime(c, t - 1.0) != fmi2Error) bad |= printf("REFUSAL MISSING: setTime backwards\n");
        fmi2FMUstate s = NULL, s2 = NULL, s3 = NULL;
        size_t n = 0;
        if (fmi2GetFMUstate(c, &s) != fmi2OK || fmi2SerializedFMUstateSize(c, s, &n) != fmi2OK) return 10;
        fmi2Byte *blob = malloc(n);
        if (!blob || fmi2SerializeFMUstate(c, s, blob, n) != fmi2OK || fmi2DeSerializeFMUstate(c, blob, n, &s2) != fmi2OK ||
            fmi2SetFMUstate(c, s2) != fmi2OK)
            return 11;
        blob[n / 2] ^= 0x01;
        if (fmi2DeSerializeFMUstate(c, blob, n, &s3) != fmi2Error) bad |= printf("REFUSAL MISSING: changed byte\n");
        fmi2FreeFMUstate(c, &s);
        fmi2FreeFMUstate(c, &s2);
        fmi2FreeFMUstate(c, &s3);
        free(blob);
        x[0] = NAN;
        if (fmi2SetContinuousStates(c, x, (size_t)nx) != fmi2Error) bad |= printf("REFUSAL MISSING: NaN state\n");
        if (fmi2GetBoolean(c, &vr_valid, 1, &valid) != fmi2OK) return 12;
        fmi2Terminate(c);
        fmi2FreeInstance(c);
    }
    printf("valid %d\n", valid ? 1 : 0);
    printf(bad ? "refusals missing\n" : "ok\n");
    dlclose(lib);
    return bad ? 1 : 0;
}
