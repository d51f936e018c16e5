"""Figures for PNG files, made and written with as little work as matplotlib allows.

Every PNG the commands write (`ballmill run`'s plots, `ballmill sweep`'s maps, curves and
scatter plots, the absorber's response curves) is made by `subplots` and written by `save`:

* `subplots` makes a `matplotlib.figure.Figure` on its own Agg canvas, without pyplot (no
  figure manager, no backend switching, no registry of open figures to close; pyplot's
  import is not needed) and at the dpi it will be written at, so that nothing is laid out
  twice;
* `save` draws the figure once (the layout engine runs inside that draw) and encodes the
  canvas's pixels as PNG at zlib level 1, rows unfiltered (`png`; RGB when every pixel is
  opaque). ``Figure.savefig`` draws a figure with a layout engine twice (once with
  rendering disabled, to lay it out, then for real) and encodes RGBA at level 6 trying five
  row filters: the same pixels cost about a third more in drawing and three to four times as
  much in encoding (our files are about a sixth larger).

``subplots(..., layout="one-axes")`` lays out a figure of one axes from the sizes of its texts
alone, once (ballmill/plotting/layout.py): the layout engines of matplotlib measure the whole
axes, ticks included, once (tight) or twice (constrained) before the draw measures it again.

`close` is there for code that is handed either this module or pyplot (a figure here needs
no closing: it is freed with its last reference).
"""
from __future__ import annotations

from pathlib import Path

DPI = 110  # the commands' PNGs: 825 x 528 pixels for a 7.5 x 4.8 in figure


def subplots(nrows: int = 1, ncols: int = 1, *, figsize=None, dpi: float = DPI, layout=None, **kw):
    """(figure, axes) as ``pyplot.subplots`` gives them (``kw``: its squeeze, sharex, ...),
    on an Agg canvas of its own, at ``dpi`` (the dpi `save` writes it at). ``layout``: a
    matplotlib layout engine or its name, or "one-axes" (ballmill.plotting.layout.OneAxes)."""
    import matplotlib as mpl
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    if layout == "one-axes":
        from .layout import OneAxes

        fig = Figure(figsize=figsize, dpi=dpi, layout=OneAxes())
        # the title at a fixed height that OneAxes sets, not moved on every draw by a measure
        # of the whole y axis (matplotlib's automatic title position)
        with mpl.rc_context({"axes.titley": 1.0}):
            axes = fig.subplots(nrows, ncols, **kw)
    else:
        fig = Figure(figsize=figsize, dpi=dpi, layout=layout)
        axes = fig.subplots(nrows, ncols, **kw)
    FigureCanvasAgg(fig)
    return fig, axes


def save(fig, path, dpi: float | None = None) -> Path:
    """The figure as a PNG file, drawn once (its layout engine included) at ``dpi`` (default:
    the figure's own)."""
    import numpy as np
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    if dpi is not None and dpi != fig.dpi:
        fig.set_dpi(dpi)
    canvas = fig.canvas if isinstance(fig.canvas, FigureCanvasAgg) else FigureCanvasAgg(fig)
    canvas.draw()
    rgba = np.asarray(canvas.buffer_rgba())
    # an opaque figure (all of them so far) as RGB: a quarter less to compress, a tenth smaller
    path = Path(path)
    path.write_bytes(png(rgba[..., :3] if rgba[..., 3].min() == 255 else rgba))
    return path


SOFTWARE = b"matplotlib (ballmill.plotting.figures)"


def png(pixels) -> bytes:
    """A PNG file of 8-bit RGB or RGBA pixels (an array of shape (height, width, 3 or 4), the
    first row at the top): every row unfiltered (filter type 0), deflated at zlib level 1, with
    a Software text chunk. Half the time of Pillow's encoder at its level 1 on a plot (which
    tries the five row filters on every row) for files ~6 % larger."""
    import struct
    import zlib

    import numpy as np

    h, w, channels = pixels.shape
    rows = np.empty((h, 1 + w * channels), dtype=np.uint8)
    rows[:, 0] = 0  # filter type None
    rows[:, 1:] = pixels.reshape(h, w * channels)

    def chunk(kind: bytes, data: bytes) -> bytes:
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))

    header = struct.pack(">IIBBBBB", w, h, 8, 2 if channels == 3 else 6, 0, 0, 0)  # 8 bits, RGB / RGBA
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header) + chunk(b"tEXt", b"Software\0" + SOFTWARE)
            + chunk(b"IDAT", zlib.compress(rows, 1)) + chunk(b"IEND", b""))


def close(fig) -> None:
    """Nothing to do for a figure made here (pyplot's close, for code handed this module)."""

