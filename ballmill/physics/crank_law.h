/* crank_law.h: the crank's start-up law and the platform point it drives, in C, as
 * ballmill/physics/drives/crank.py computes them, in the same operation order (bit for bit):
 * written once for the compiled kernel (_kernel.c: the CrankStartup motion and the Fig. 1
 * machine's shafts) and the native drive models (motorstartup.c, inductionmotor.c through
 * drive_models/crank_kinematics.h, fig1drive.c), whose sources/ folders carry it
 * (ballmill/fmi/native.py).
 *
 * startup_angle: a speed rise from rest at t = 0 to the rate w0 (rad/s) in t0 (s), w0 kept
 * after t0, at rest before t = 0, in the shape `law` chooses (STARTUP_QUADRATIC, the paper's,
 * STARTUP_SCURVE, STARTUP_LINEAR, STARTUP_QUINTIC: MotorStartup's parameter `law`), as
 * crank.rise_angle computes it. out = (angle, rate, acceleration) in rad, rad/s, rad/s^2.
 *
 * crank_kinematics: the platform point O1 driven by a crank of length l at angle psi, as
 * CrankStartup.state computes it: from psi, psi' and psi'' (rad, rad/s, rad/s^2) position
 * x1O, y1O (m), velocity vx1O, vy1O (m/s) and acceleration ax1O, ay1O (m/s^2). */
#ifndef CRANK_LAW_H
#define CRANK_LAW_H

#include <math.h>

enum { STARTUP_QUADRATIC = 1, STARTUP_SCURVE = 2, STARTUP_LINEAR = 3, STARTUP_QUINTIC = 4 };

static inline void startup_angle(int law, double w0, double t0, double t, double out[3])
{
    if (t < 0.0) {
        out[0] = 0.0; out[1] = 0.0; out[2] = 0.0;
    } else if (law == STARTUP_QUADRATIC) {
        if (t <= t0) {
            double s = t / t0, u = 1.0 - s;
            out[0] = w0 * t0 * s * s * (1.0 - s / 3.0); /* crank.rise_angle's form: 0 at t = 0 */
            out[1] = w0 * (1.0 - u * u);
            out[2] = 2.0 * w0 * u / t0;
        } else {
            out[0] = 2.0 / 3.0 * w0 * t0 + w0 * (t - t0);
            out[1] = w0;
            out[2] = 0.0;
        }
    } else if (t > t0) { /* every other law: angle = w0 t0 / 2 + w0 (t - t0) after the rise */
        out[0] = 0.5 * w0 * t0 + w0 * (t - t0);
        out[1] = w0;
        out[2] = 0.0;
    } else {
        double s = t / t0;
        if (law == STARTUP_LINEAR) {
            out[0] = 0.5 * w0 * t0 * s * s;
            out[1] = w0 * s;
            out[2] = w0 / t0;
        } else if (law == STARTUP_SCURVE) {
            out[0] = w0 * t0 * s * s * s * (1.0 - 0.5 * s);
            out[1] = w0 * s * s * (3.0 - 2.0 * s);
            out[2] = 6.0 * w0 * s * (1.0 - s) / t0;
        } else { /* STARTUP_QUINTIC */
            double u = 1.0 - s;
            out[0] = w0 * t0 * pow(s, 4.0) * (2.5 - 3.0 * s + s * s);
            out[1] = w0 * pow(s, 3.0) * (10.0 - 15.0 * s + 6.0 * s * s);
            out[2] = 30.0 * w0 * s * s * u * u / t0;
        }
    }
}

typedef struct {
    double x, y, vx, vy, ax, ay;
} crank_point;

static inline crank_point crank_kinematics(double l, double psi, double pd, double pdd)
{
    double c = cos(psi), s = sin(psi);
    crank_point o;
    o.x = l * c;
    o.y = l * s;
    o.vx = -l * s * pd;
    o.vy = l * c * pd;
    o.ax = -l * (s * pdd + c * pd * pd);
    o.ay = l * (c * pdd - s * pd * pd);
    return o;
}

#endif
