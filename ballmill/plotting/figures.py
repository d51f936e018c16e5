"""Figures for PNG files, made and written with as little work as matplotlib allows.

Every PNG the commands write (`ballmill run`'s plots, `ballmill sweep`'s maps, curves and
scatter plots, the absorber's response curves) is made by `subplots` and written by `save`:

* `subplots` makes a `matplotlib.figure.Figure` on its own Agg canvas, without pyplot (no
  figure manager, no backend switching, no registry of open figures to close; pyplot's
  import is not needed) and at the dpi it will be written at, so that nothing is laid out
  twice;
* `save` draws the figure once (the layout engine, constrained or tight, runs inside that
  draw) and encodes the canvas's pixels as PNG at zlib level 1 (RGB when every pixel is
  opaque). ``Figure.savefig`` draws a figure with a layout engine twice (once with
  rendering disabled, to lay it out, then for real) and encodes RGBA at level 6: the same
  pixels cost about a third more in drawing and twice as much in encoding (level 1 files
  are ~10 % larger).

`Writer` saves several figures at once: after the first (drawn in the command), each `save`
forks a process that draws and writes that figure as it stands when the call is made (a
figure reused for the next PNG can be changed right away), at most one process per idle
core at a time, so that on free cores a
command's PNGs take about the wall time of the slowest share rather than of all of them (the
drawing costs somewhat more CPU that way: on a busy machine, or without os.fork, it saves in
the calling process).

`close` is there for code that is handed either this module or pyplot (a figure here needs
no closing: it is freed with its last reference).
"""
from __future__ import annotations

import os
import sys
from pathlib import Path

DPI = 110  # the commands' PNGs: 825 x 528 pixels for a 7.5 x 4.8 in figure


def subplots(nrows: int = 1, ncols: int = 1, *, figsize=None, dpi: float = DPI, layout=None, **kw):
    """(figure, axes) as ``pyplot.subplots`` gives them (``kw``: its squeeze, sharex, ...),
    on an Agg canvas of its own, at ``dpi`` (the dpi `save` writes it at)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=figsize, dpi=dpi, layout=layout)
    FigureCanvasAgg(fig)
    return fig, fig.subplots(nrows, ncols, **kw)


def save(fig, path, dpi: float | None = None) -> Path:
    """The figure as a PNG file, drawn once (its layout engine included) at ``dpi`` (default:
    the figure's own)."""
    import numpy as np
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from PIL import Image, PngImagePlugin

    if dpi is not None and dpi != fig.dpi:
        fig.set_dpi(dpi)
    canvas = fig.canvas if isinstance(fig.canvas, FigureCanvasAgg) else FigureCanvasAgg(fig)
    canvas.draw()
    w, h = canvas.get_width_height(physical=True)
    info = PngImagePlugin.PngInfo()
    info.add_text("Software", "matplotlib (ballmill.plotting.figures)")
    path = Path(path)
    rgba = np.asarray(canvas.buffer_rgba())
    # an opaque figure (all of them so far) as RGB: a third less to compress, a tenth smaller
    image = Image.fromarray(rgba[..., :3], "RGB") if rgba[..., 3].min() == 255 else \
        Image.frombuffer("RGBA", (w, h), rgba, "raw", "RGBA", 0, 1)
    image.save(path, format="png", compress_level=1, pnginfo=info)
    return path


def close(fig) -> None:
    """Nothing to do for a figure made here (pyplot's close, for code handed this module)."""


def _cores() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except (AttributeError, OSError):
        return os.cpu_count() or 1


def _idle_jobs() -> int:
    """How many drawings can run side by side: the cores this process may use that the load
    average (last minute; this command counts as one) leaves free, at least 1. A forked drawing
    costs more CPU than one in the command (its copied pages, caches it starts again), which
    pays off only on a core nothing else wants."""
    cores = _cores()
    try:
        load = os.getloadavg()[0]
    except (AttributeError, OSError):
        return cores
    return max(1, min(cores, int(cores - load + 1.5)))


class Writer:
    """Figures saved as PNG files in forked processes, at most ``jobs`` (default: the cores this
    process may use that the load leaves free) drawing at a time; `wait` (or leaving the ``with`` block) waits for all
    and raises if one failed (its traceback is on stderr). Each `save` draws the figure as it
    is when called. The first figure is drawn in the calling process (the forked drawings
    start from the caches it fills: without it each would redo that work, about 40 % more CPU
    for a sweep's heat maps); all of them there when ``jobs`` is 1 or os.fork is missing."""

    def __init__(self, jobs: int | None = None):
        self.jobs = jobs if jobs is not None else _idle_jobs()
        self.fork = self.jobs > 1 and hasattr(os, "fork") and sys.platform.startswith("linux")
        self._running: dict[int, Path] = {}
        self._failed: list[str] = []
        self._warm = False

    def __enter__(self):
        return self

    def __exit__(self, kind, value, tb):
        if kind is None:
            self.wait()
        else:  # an error in the caller: reap the children, report the caller's error
            self._reap(len(self._running))

    def save(self, fig, path, dpi: float | None = None) -> Path:
        path = Path(path)
        if not self.fork or not self._warm:
            # the first figure here: its drawing fills matplotlib's caches (fonts, text
            # metrics, a reused figure's layout) that every forked drawing then starts with
            self._warm = True
            return save(fig, path, dpi)
        if len(self._running) >= self.jobs:
            self._reap(1)
        sys.stdout.flush()
        sys.stderr.flush()
        pid = os.fork()
        if pid == 0:  # the child: draw, write, leave without running the parent's exit handlers
            status = 1
            try:
                save(fig, path, dpi)
                status = 0
            except BaseException:
                import traceback

                traceback.print_exc()
            finally:
                try:
                    sys.stderr.flush()
                finally:
                    os._exit(status)
        self._running[pid] = path
        return path

    def _reap(self, n: int) -> None:
        for pid in list(self._running)[:n]:  # the oldest first; only our own children
            _, status = os.waitpid(pid, 0)
            path = self._running.pop(pid)
            if os.waitstatus_to_exitcode(status) != 0:
                self._failed.append(f"{path} (exit status {os.waitstatus_to_exitcode(status)})")

    def wait(self) -> None:
        self._reap(len(self._running))
        if self._failed:
            failed, self._failed = self._failed, []
            raise RuntimeError(f"drawing a figure failed in a forked process: {', '.join(failed)}; "
                               "the traceback is on stderr above")
