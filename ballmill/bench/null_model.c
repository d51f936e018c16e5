/* ballmill/bench/null_model.c: a native FMU that does nothing (y = u at every step), on
 * the project's FMI plumbing. `ballmill bench` times it through fmpy: what one
 * communication step costs before any model runs (the master's per-call floor). */
#include <stddef.h>

#include "fmu_model.h"
#include "Null_interface.h"

typedef struct {
    double unused;
} null_model;

static fmi2Status setup(fmu_instance *fi, void *data, double *v, double t)
{
    (void)fi;
    (void)data;
    (void)t;
    v[VR_y] = v[VR_u];
    return fmi2OK;
}

static fmi2Status step(fmu_instance *fi, void *data, double *v, double t, double t_end)
{
    (void)fi;
    (void)data;
    (void)t;
    (void)t_end;
    v[VR_y] = v[VR_u];
    return fmi2OK;
}

const fmu_model FMU_MODEL = { /* nothing to check, no direct feedthrough, no Model Exchange */
    FMU_IDENTIFIER, FMU_GUID, FMU_N_VARS, FMU_VARIABLES, sizeof(null_model), 0, setup, step, NULL, NULL, NULL,
};
