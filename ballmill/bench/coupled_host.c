/* ballmill/bench/coupled_host.c: the smallest master of the coupled fast start, in C, to time
 * what the native FMUs themselves cost per communication step (ballmill bench, section
 * "The same in libcosim").
 *
 * It dlopens MotorStartup and BallInShell, instantiates both with their default parameters
 * (those of the fast start), and steps them as libcosim's fixed-step algorithm does (Jacobi:
 * at each communication point read every connected output, set every input, then step
 * both): the drive's platform motion (6 Reals) into the ball, the ball's M_reaction into the
 * drive. Even cycles time the whole run as one (the FMUs' calls and the host's seven
 * copies: the FMUs' time per step); odd cycles read CLOCK_MONOTONIC around each FMU's own
 * calls (fmi2SetReal, fmi2DoStep, fmi2GetReal) for the split between the two. Every status
 * is checked.
 *
 *   coupled_host DRIVE_LIB DRIVE_GUID DRIVE_RES BALL_LIB BALL_GUID BALL_RES STEPS H CYCLES
 *                DRIVE_OUT_VRS BALL_IN_VRS BALL_OUT_VR DRIVE_IN_VR BALL_ZP_VR
 *
 * (the *_VRS are six comma-separated value references: x1O, y1O, vx1O, vy1O, ax1O, ay1O)
 * prints one line per cycle, times in us per step: "split wall cpu drive ball zP_end" (wall and
 * cpu: the whole loop, elapsed and this thread's CPU time; split 0: drive and ball 0; split 1:
 * the clock read around each FMU's calls; zP_end: BallInShell's zP after the last step)
 * and exits 0 only when every call returned fmi2OK or fmi2Warning.
 */
#define _POSIX_C_SOURCE 199309L
#include <dlfcn.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <time.h>

#include "fmi2Functions.h"

#define N_PLATFORM 6

typedef struct {
    void *lib;
    fmi2InstantiateTYPE *instantiate;
    fmi2SetupExperimentTYPE *setup;
    fmi2EnterInitializationModeTYPE *enter_init;
    fmi2ExitInitializationModeTYPE *exit_init;
    fmi2DoStepTYPE *do_step;
    fmi2GetRealTYPE *get_real;
    fmi2SetRealTYPE *set_real;
    fmi2TerminateTYPE *terminate;
    fmi2FreeInstanceTYPE *free_instance;
} Fmu;

static void logger(fmi2ComponentEnvironment env, fmi2String name, fmi2Status status, fmi2String category,
                   fmi2String message, ...)
{
    va_list ap;
    (void)env;
    if (status == fmi2OK) return;
    fprintf(stderr, "[%s %d %s] ", name, (int)status, category);
    va_start(ap, message);
    vfprintf(stderr, message, ap);
    va_end(ap);
    fputc('\n', stderr);
}

static int load(Fmu *f, const char *path)
{
    f->lib = dlopen(path, RTLD_NOW | RTLD_LOCAL);
    if (!f->lib) {
        fprintf(stderr, "coupled_host: %s\n", dlerror());
        return 0;
    }
#define SYM(field, name)                                                               \
    f->field = (name##TYPE *)dlsym(f->lib, #name);                                     \
    if (!f->field) {                                                                   \
        fprintf(stderr, "coupled_host: %s missing from %s\n", #name, path);             \
        return 0;                                                                      \
    }
    SYM(instantiate, fmi2Instantiate)
    SYM(setup, fmi2SetupExperiment)
    SYM(enter_init, fmi2EnterInitializationMode)
    SYM(exit_init, fmi2ExitInitializationMode)
    SYM(do_step, fmi2DoStep)
    SYM(get_real, fmi2GetReal)
    SYM(set_real, fmi2SetReal)
    SYM(terminate, fmi2Terminate)
    SYM(free_instance, fmi2FreeInstance)
#undef SYM
    return 1;
}

static int parse_vrs(const char *text, fmi2ValueReference *out, int n)
{
    char *end;
    for (int i = 0; i < n; i++) {
        out[i] = (fmi2ValueReference)strtoul(text, &end, 10);
        if (end == text || (i < n - 1 && *end != ',') || (i == n - 1 && *end != '\0')) return 0;
        text = end + 1;
    }
    return 1;
}

static double now_s(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* this thread's CPU time: what the loop costs, without the time other processes take the
 * core away (read only at the ends of a cycle) */
static double cpu_s(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

#define CHECK(call)                                                                    \
    do {                                                                               \
        fmi2Status s_ = (call);                                                        \
        if (s_ > fmi2Warning) {                                                        \
            fprintf(stderr, "coupled_host: %s returned %d at step %ld\n", #call, (int)s_, k); \
            ok = 0;                                                                    \
        }                                                                              \
    } while (0)

int main(int argc, char **argv)
{
    if (argc != 15) {
        fprintf(stderr, "usage: coupled_host DRIVE_LIB DRIVE_GUID DRIVE_RES BALL_LIB BALL_GUID BALL_RES STEPS H "
                        "CYCLES DRIVE_OUT_VRS BALL_IN_VRS BALL_OUT_VR DRIVE_IN_VR BALL_ZP_VR\n");
        return 2;
    }
    Fmu drive, ball;
    fmi2ValueReference drive_out[N_PLATFORM], ball_in[N_PLATFORM];
    long steps = atol(argv[7]), cycles = atol(argv[9]);
    double h = atof(argv[8]);
    fmi2ValueReference ball_out = (fmi2ValueReference)atol(argv[12]);
    fmi2ValueReference drive_in = (fmi2ValueReference)atol(argv[13]);
    fmi2ValueReference ball_zp = (fmi2ValueReference)atol(argv[14]);
    if (!parse_vrs(argv[10], drive_out, N_PLATFORM) || !parse_vrs(argv[11], ball_in, N_PLATFORM)) {
        fprintf(stderr, "coupled_host: expected six comma-separated value references, got %s and %s\n",
                argv[10], argv[11]);
        return 2;
    }
    if (steps < 1 || cycles < 1 || !(h > 0.0)) {
        fprintf(stderr, "coupled_host: STEPS and CYCLES must be >= 1 and H > 0\n");
        return 2;
    }
    if (!load(&drive, argv[1]) || !load(&ball, argv[4])) return 2;
    fmi2CallbackFunctions cb = {logger, calloc, free, NULL, NULL};
    int ok = 1;
    for (long c = 0; c < cycles && ok; c++) {
        long k = -1;
        fmi2Component d = drive.instantiate("drive", fmi2CoSimulation, argv[2], argv[3], &cb, fmi2False, fmi2False);
        fmi2Component b = ball.instantiate("ball", fmi2CoSimulation, argv[5], argv[6], &cb, fmi2False, fmi2False);
        if (!d || !b) {
            fprintf(stderr, "coupled_host: fmi2Instantiate returned NULL\n");
            if (d) drive.free_instance(d);
            if (b) ball.free_instance(b);
            return 1;
        }
        double platform[N_PLATFORM], m_reaction = 0.0, zp = 0.0;
        CHECK(drive.setup(d, fmi2False, 0.0, 0.0, fmi2False, 0.0));
        CHECK(ball.setup(b, fmi2False, 0.0, 0.0, fmi2False, 0.0));
        CHECK(drive.enter_init(d));
        CHECK(ball.enter_init(b));
        /* initialisation as the master's: the drive's outputs into the ball, the ball's back */
        CHECK(drive.get_real(d, drive_out, N_PLATFORM, platform));
        CHECK(ball.set_real(b, ball_in, N_PLATFORM, platform));
        CHECK(ball.get_real(b, &ball_out, 1, &m_reaction));
        CHECK(drive.set_real(d, &drive_in, 1, &m_reaction));
        CHECK(drive.exit_init(d));
        CHECK(ball.exit_init(b));
        /* even cycles: the whole loop timed once, nothing inside it but the calls and seven
         * copies; odd cycles: the clock read around each FMU's calls, for the split (the reads
         * themselves add about 0.1 us per step) */
        int split = (int)(c % 2);
        double in_drive = 0.0, in_ball = 0.0, t_start = now_s(), cpu_start = cpu_s();
        for (k = 0; k < steps && ok; k++) {
            double t = (double)k * h;
            if (!split) {
                CHECK(drive.get_real(d, drive_out, N_PLATFORM, platform));
                CHECK(ball.get_real(b, &ball_out, 1, &m_reaction));
                CHECK(ball.set_real(b, ball_in, N_PLATFORM, platform));
                CHECK(drive.set_real(d, &drive_in, 1, &m_reaction));
                CHECK(drive.do_step(d, t, h, fmi2True));
                CHECK(ball.do_step(b, t, h, fmi2True));
                continue;
            }
            double t0 = now_s();
            CHECK(drive.get_real(d, drive_out, N_PLATFORM, platform));
            double t1 = now_s();
            CHECK(ball.get_real(b, &ball_out, 1, &m_reaction));
            CHECK(ball.set_real(b, ball_in, N_PLATFORM, platform));
            double t2 = now_s();
            CHECK(drive.set_real(d, &drive_in, 1, &m_reaction));
            CHECK(drive.do_step(d, t, h, fmi2True));
            double t3 = now_s();
            CHECK(ball.do_step(b, t, h, fmi2True));
            double t4 = now_s();
            in_drive += (t1 - t0) + (t3 - t2);
            in_ball += (t2 - t1) + (t4 - t3);
        }
        double wall = now_s() - t_start, cpu = cpu_s() - cpu_start;
        CHECK(ball.get_real(b, &ball_zp, 1, &zp));
        CHECK(drive.terminate(d));
        CHECK(ball.terminate(b));
        drive.free_instance(d);
        ball.free_instance(b);
        if (ok)
            printf("%d %.6f %.6f %.6f %.6f %.17g\n", split, wall / (double)steps * 1e6, cpu / (double)steps * 1e6,
                   in_drive / (double)steps * 1e6, in_ball / (double)steps * 1e6, zp);
    }
    dlclose(ball.lib);
    dlclose(drive.lib);
    return ok ? 0 : 1;
}
