"""A synthetic evaluator for the design commands' tests: indicators in closed form of a point's
parameters (no physics), registered as model.kind = "design-toy" on the fast start's scenario,
whose ball's initial spins wx0, wy0, wz0 [rad/s] take any real value and serve as the variables.

Indicators (x, y, z: the point's ball.wx0, ball.wy0, ball.wz0, 0 when not varied):

* bowl = (x - 0.3)^2 + (y + 1.2)^2 + 1, its minimum 1 at (0.3, -1.2);
* plane = x + y;
* zdt_f1 = x, zdt_f2 = g (1 - sqrt(x / g)), g = 1 + 9 y (ZDT1 with two variables in [0, 1]:
  its Pareto front is y = 0, f2 = 1 - sqrt(f1)); neg_zdt_f2 = -zdt_f2 (to be maximised);
* ishigami = sin x + 7 sin^2 y + 0.1 z^4 sin x (Ishigami and Homma, A = 7, B = 0.1);
* valid: false where x < -3.5 (outside the Ishigami and ZDT domains), t_invalid = 10 (x + 4.5) s there (so that its margin grows towards
  validity); then the indicators are not reported, as a physical point's past its validity.

Environment (for the resume test's subprocess): BALLMILL_TOY_LOG, a file that gets one line
per point evaluated (its parameters as JSON); BALLMILL_TOY_KILL_AFTER = K: the process kills
itself (SIGKILL, no clean-up) when asked for the (K + 1)-th point.
"""
from __future__ import annotations

import json
import math
import os
import signal

from ballmill.sweep import evaluators

KIND = "design-toy"
INDICATORS = {"bowl": ("1", "(x - 0.3)^2 + (y + 1.2)^2 + 1"), "plane": ("1", "x + y"),
              "zdt_f1": ("1", "ZDT1 f1"), "zdt_f2": ("1", "ZDT1 f2"), "neg_zdt_f2": ("1", "-ZDT1 f2"),
              "ishigami": ("1", "Ishigami's function")}
_count = [0]


class ToyPrepared(evaluators.Prepared):
    model = "design-toy: closed form"

    def __init__(self):
        self.timing = {}

    def run(self, params):
        _count[0] += 1
        kill = os.environ.get("BALLMILL_TOY_KILL_AFTER")
        if kill and _count[0] > int(kill):
            os.kill(os.getpid(), signal.SIGKILL)
        log = os.environ.get("BALLMILL_TOY_LOG")
        if log:
            with open(log, "a") as f:
                f.write(json.dumps(params, sort_keys=True) + "\n")
        return dict(params), {"model": self.model, "error_P_m": 0.0, "error_N_N": 0.0, "error_method": "exact"}

    def evaluate(self, p, custom):
        x, y, z = (float(p.get(f"ball.w{k}0", 0.0)) for k in "xyz")
        if x < -3.5:
            return {**{k: None for k in INDICATORS}, "valid": False, "t_invalid": 10.0 * (x + 4.5)}
        g = 1.0 + 9.0 * y
        f2 = g * (1.0 - math.sqrt(x / g)) if x >= 0 and g > 0 else None  # (ZDT1 is defined on [0, 1]^2)
        return {"bowl": (x - 0.3) ** 2 + (y + 1.2) ** 2 + 1.0, "plane": x + y, "zdt_f1": x, "zdt_f2": f2,
                "neg_zdt_f2": None if f2 is None else -f2,
                "ishigami": math.sin(x) + 7.0 * math.sin(y) ** 2 + 0.1 * z ** 4 * math.sin(x),
                "valid": True, "t_invalid": None}


class Toy(evaluators.Evaluator):
    kind = KIND
    description = "closed-form indicators of the parameters (tests)"
    indicators = INDICATORS

    def check(self, sc):
        return ""

    def prepare(self, sc, study, build_dir=None):
        return ToyPrepared()


def register():
    evaluators.register(Toy())


def unregister():
    evaluators.REGISTRY.pop(KIND, None)
    if KIND in evaluators.ORDER:
        evaluators.ORDER.remove(KIND)
