/* crank_kinematics.h: the platform point O1 driven by a crank of length l at angle psi,
 * as CrankStartup.state computes it (ballmill/physics/drives/crank.py); shared by the
 * native drive models motorstartup.c and inductionmotor.c, whose sources/ folders carry
 * this header (ballmill/fmi/native.py, MODEL_HEADERS).
 *
 * From psi, psi' and psi'' (rad, rad/s, rad/s^2): position x1O, y1O (m), velocity
 * vx1O, vy1O (m/s) and acceleration ax1O, ay1O (m/s^2), in this operation order.
 * crank_publish stores psi, its derivatives and the platform point into a model's
 * value array through the VR_* constants of the model's generated interface header,
 * which must be included before this one (both drive models declare these outputs,
 * ballmill/fmi/interface.py CRANK_KINEMATICS). */
#ifndef CRANK_KINEMATICS_H
#define CRANK_KINEMATICS_H

#include <math.h>

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

static inline void crank_publish(double *v, double l, double psi, double pd, double pdd)
{
    crank_point o = crank_kinematics(l, psi, pd, pdd);
    v[VR_psi] = psi;
    v[VR_psi_dot] = pd;
    v[VR_psi_ddot] = pdd;
    v[VR_x1O] = o.x;
    v[VR_y1O] = o.y;
    v[VR_vx1O] = o.vx;
    v[VR_vy1O] = o.vy;
    v[VR_ax1O] = o.ax;
    v[VR_ay1O] = o.ay;
}

#endif
