"""Where the library's time goes: a measured decomposition and a cProfile listing."""
from __future__ import annotations

import cProfile
import io
import pstats

from ballmill.physics import simulate

from .micro import mid_run_state, per_call_us
from .problem import Problem, library_model, median_time


def decomposition(problem: Problem, formulation: str, method: str, param: float, repeats: int,
                  min_time: float = 0.1, total: float | None = None, repeats_unit: int = 7):
    """Split one monolithic run (``total`` [s], measured here when None) into: right-hand sides (nfev x cost of one f(t, y)
    call, itself split into drive and equations), outputs on the grid (points x
    cost of one outputs evaluation), and the rest (integrator and driver)."""
    drive = problem.drive

    def run():
        model = library_model(problem, formulation, method, param)
        simulate(model, drive, t_end=problem.t_end, dt=problem.dt, kernel="python")
        return model

    if total is None:  # else: the sweep's round-robin median, steadier than a new series
        total, _, model = median_time(run, repeats)
        source = f"median of {repeats} runs"
    else:
        model = run()
        source = "the sweep's median, section 2"
    nfev, steps = model.info.nfev, model.info.steps
    probe = library_model(problem, formulation, method, param)
    st = mid_run_state(problem, probe, 5.0)
    f = probe.rhs(drive.accel)
    y = st.y.copy()
    yl = y.tolist()
    ax, ay = drive.accel(5.0)
    t_f = per_call_us(lambda: f(5.0, y), repeats_unit, min_time)[0] * 1e-6
    t_acc = per_call_us(lambda: drive.accel(5.0), repeats_unit, min_time)[0] * 1e-6
    t_der = per_call_us(lambda: probe.form.derivative(yl, ax, ay), repeats_unit, min_time)[0] * 1e-6

    def one_output():
        x, yy, _, _, ax_, ay_ = drive.state(5.0)
        return probe.outputs(st, ax_, ay_, x, yy)

    t_out = per_call_us(one_output, repeats_unit, min_time)[0] * 1e-6
    n_out = problem.n_out
    rows = [
        (f"right-hand sides: {nfev} x f(t, y) at {t_f * 1e6:.2f} µs (drive {t_acc * 1e6:.2f}, "
         f"equations {t_der * 1e6:.2f}, rest: closure and y.tolist())", nfev * t_f),
        (f"outputs on the grid: {n_out} x (drive.state + evaluate) at {t_out * 1e6:.2f} µs", n_out * t_out),
    ]
    rest = total - sum(v for _, v in rows)
    rows.append(("integrator + driver (stage arithmetic, error norm, control, arrays): the remainder", rest))
    return {"total": total, "source": source, "nfev": nfev, "steps": steps, "rows": rows, "rhs": nfev * t_f,
            "outputs": n_out * t_out, "per_step_us": total / max(steps, 1) * 1e6, "t_f_us": t_f * 1e6,
            "t_acc_us": t_acc * 1e6, "t_der_us": t_der * 1e6}


def cprofile_top(problem: Problem, formulation: str, method: str, param: float, top: int = 14):
    model = library_model(problem, formulation, method, param)
    prof = cProfile.Profile()
    prof.enable()
    simulate(model, problem.drive, t_end=problem.t_end, dt=problem.dt, kernel="python")
    prof.disable()
    stats = pstats.Stats(prof, stream=io.StringIO())
    total = stats.total_tt
    rows = []
    for (fname, line, func), (cc, nc, tt, ct, _) in sorted(stats.stats.items(), key=lambda kv: -kv[1][2])[:top]:
        short = fname.split("ballmill/")[-1] if "ballmill/" in fname else fname.rsplit("/", 1)[-1]
        rows.append((f"{short}:{line}({func})", nc, tt, ct))
    return total, rows
