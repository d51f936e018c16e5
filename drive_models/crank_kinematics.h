/* crank_kinematics.h: the crank outputs of the native drive models motorstartup.c and
 * inductionmotor.c, whose sources/ folders carry this header (ballmill/fmi/native.py,
 * MODEL_HEADERS). The platform point itself is crank_law.h's crank_kinematics.
 * crank_publish stores psi, its derivatives and the platform point into a model's
 * value array through the VR_* constants of the model's generated interface header,
 * which must be included before this one (both drive models declare these outputs,
 * ballmill/fmi/interface.py CRANK_KINEMATICS). */
#ifndef CRANK_KINEMATICS_H
#define CRANK_KINEMATICS_H

#include "crank_law.h"

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
