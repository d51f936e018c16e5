"""A layout engine for a figure of one axes, placed once from the sizes of its texts.

matplotlib's engines measure the whole axes to lay it out: tight once, constrained twice
(its tick objects made, every tick label laid out, the axis labels placed), and the draw that
follows measures it all again: on `ballmill run`'s figures that is a third of drawing them.
`OneAxes` measures only the texts around the axes, the tick labels as the axis' locator and
formatter give them (no tick objects), through matplotlib's text-metrics cache, which the
draw then reuses. It knows where matplotlib puts those texts for an axes with ticks and
labels at the bottom and left (the defaults): the tick labels at the ticks' pad, the axis
labels at their labelpad beyond them, the offset texts (e.g. "1e-3") at the axis' end, the
title above the axes. A legend made by `legend_below` goes under the x label.
"""
from __future__ import annotations

from matplotlib import transforms
from matplotlib.layout_engine import LayoutEngine
from matplotlib.text import Text

PAD = 4.0  # from the figure's edges to the nearest text [pt]
LEGEND_GAP = 4.0  # from the x label (or the tick labels) down to the legend [pt]
TITLE_GAP = 2.0  # between the y axis' offset text (e.g. "1e-3") and the title above it [pt]
BELOW = "_ballmill_below"  # the mark of a legend that legend_below made


class OneAxes(LayoutEngine):
    """The layout of a figure of one axes, set when the figure is drawn, from the sizes of
    its texts: the title (and the y axis' offset text) above the axes, the tick labels,
    the axis labels and the x axis' offset text beside and below, a legend centred under
    the x label (`legend_below`), every one of them PAD points or more inside the figure.
    The tick labels are measured as the axis' locator and formatter give them, without the
    ticks themselves. An axes of equal aspect (adjustable "datalim") keeps half of its widest
    tick label beyond both ends of each axis (its limits follow the new box, and its ticks
    move with them), and is measured again when the new limits bring wider labels."""
    _adjust_compatible = False
    _colorbar_gridspec = False

    def execute(self, fig):
        (ax,) = fig.axes
        renderer = fig.canvas.get_renderer()
        px = fig.dpi / 72.0  # pixels per point
        W, H = fig.bbox.width, fig.bbox.height
        box = ax.bbox  # the axes' box now [px]: the texts' overhangs beyond it are measured

        def size(text: str, like) -> tuple[float, float]:
            """(width, height) [px] of ``text`` in ``like``'s font (matplotlib's metrics
            cache keeps them for the draw)."""
            t = Text(0.0, 0.0, text, fontproperties=like.get_fontproperties(),
                     rotation=like.get_rotation())
            t.set_figure(fig)
            b = t.get_window_extent(renderer)
            return b.width, b.height

        def ticks(axis):
            """(positions in the axes [0, 1], (width, height) [px] of each label), and the
            offset text's height [px] (0 without one)."""
            tick = axis.majorTicks[0]  # the first tick: the draw makes and keeps it anyway
            if not tick.label1.get_visible():
                return tick, [], [], 0.0
            locs = axis.get_majorticklocs()
            labels = axis.major.formatter.format_ticks(locs)
            lo, hi = sorted(axis.get_view_interval())
            where, sizes = [], []
            for loc, label in zip(locs, labels):
                if label and lo - 1e-10 * (hi - lo) <= loc <= hi + 1e-10 * (hi - lo):
                    where.append((loc - lo) / (hi - lo) if hi > lo else 0.5)
                    sizes.append(size(label, tick.label1))
            offset = axis.major.formatter.get_offset()
            return tick, where, sizes, (size(offset, axis.offsetText)[1] if offset else 0.0)

        def extent(artist):
            return artist.get_window_extent(renderer) if artist.get_visible() and (
                not isinstance(artist, Text) or artist.get_text()) else None

        title = ax.title if ax.title.get_text() else None
        legend = ax.get_legend()
        legend = legend if legend is not None and getattr(legend, BELOW, False) else None
        # an axes of equal aspect changes its limits with its box, and its ticks move: a tick
        # label may then stand at either end of an axis, half of it beyond the axes
        moving = ax.get_aspect() != "auto" and ax.get_adjustable() == "datalim"
        for _ in range(3):  # moving: once more if the new limits bring wider labels
            xt, xwhere, xsizes, x_offset = ticks(ax.xaxis)
            yt, ywhere, ysizes, y_offset = ticks(ax.yaxis)
            if moving:
                xwhere, xsizes = [0.0, 1.0], [max(xsizes, default=(0.0, 0.0), key=lambda s: s[0])] * 2
                ywhere, ysizes = [0.0, 1.0], [max(ysizes, default=(0.0, 0.0), key=lambda s: s[0])] * 2
            # below: the tick labels, then the x label (or the offset text at the right)
            down = (xt.get_pad() + xt.get_tick_padding()) * px + max((h for _, h in xsizes), default=0.0)
            xlabel = extent(ax.xaxis.label)
            below = max(ax.xaxis.labelpad * px + (xlabel.height if xlabel else 0.0),
                        ax.xaxis.OFFSETTEXTPAD * px + x_offset if x_offset else 0.0)
            down += below
            # left: the tick labels, then the y label
            ylabel = extent(ax.yaxis.label)
            left = (yt.get_pad() + yt.get_tick_padding()) * px + max((w for w, _ in ysizes), default=0.0) \
                + (ax.yaxis.labelpad * px + ylabel.width if ylabel else 0.0)
            # above: the y axis' offset text, the title over it
            up = ax.yaxis.OFFSETTEXTPAD * px + y_offset if y_offset else 0.0
            lift = 0.0  # how far the title goes up to clear the offset text [px]
            if title is not None:
                title.set_y(1.0)
                t = title.get_window_extent(renderer)
                if y_offset:
                    lift = max(0.0, up + TITLE_GAP * px - (t.y0 - box.y1))
                up = max(up, t.y1 - box.y1 + lift)
            up = max(up, max((h / 2 - (1 - f) * box.height for f, (_, h) in zip(ywhere, ysizes)), default=0.0))
            if legend is not None:  # its top LEGEND_GAP under the x label, centred under the axes
                legend.set_bbox_to_anchor((0.5, 0.0), transform=ax.transAxes + transforms.ScaledTranslation(
                    0.0, -(down + LEGEND_GAP * px) / fig.dpi, fig.dpi_scale_trans))
                lb = legend.get_window_extent(renderer)
                down = box.y0 - lb.y0
            # the box, then what sticks out sideways of it at that width (the title, the x label
            # and the legend are centred on it)
            wide = [b.width for b in (t if title is not None else None, xlabel,
                                      lb if legend is not None else None) if b is not None]
            x0, x1 = PAD * px + left, W - PAD * px
            right = 0.0
            for _ in range(2):
                w = x1 - x0
                side = max((s / 2 - w / 2 for s in wide), default=0.0)
                right = max(0.0, side, max((s[0] / 2 - (1 - f) * w for f, s in zip(xwhere, xsizes)), default=0.0))
                lead = max(left, side, max((s[0] / 2 - f * w for f, s in zip(xwhere, xsizes)), default=0.0))
                x0, x1 = PAD * px + lead, W - PAD * px - right
            y0, y1 = PAD * px + down, H - PAD * px - up
            if ylabel is not None:  # centred on the axes: a label taller than them moves their centre
                half = ylabel.height / 2
                y1 = min(y1, 2 * (H - PAD * px - half) - y0)
                y0 = max(y0, 2 * (PAD * px + half) - y1)
            pos = transforms.Bbox.from_extents(x0 / W, y0 / H, x1 / W, y1 / H)
            ax._set_position(pos, which="both")  # noqa: SLF001 (what a layout engine sets)
            if title is not None:
                for text in (ax.title, ax._left_title, ax._right_title):  # noqa: SLF001
                    text.set_y(1.0 + lift / (y1 - y0))
            if not moving:
                break
            ax.apply_aspect(pos)
            box = ax.bbox
            _, _, xs, xo = ticks(ax.xaxis)
            _, _, ys, yo = ticks(ax.yaxis)
            if (xo, yo) == (x_offset, y_offset) and all(w <= xsizes[0][0] and h <= xsizes[0][1] for w, h in xs) \
                    and all(w <= ysizes[0][0] and h <= ysizes[0][1] for w, h in ys):
                break


def legend_below(ax, **kw):
    """The axes' legend, centred under its x label by `OneAxes` (``kw``: ``Axes.legend``'s)."""
    leg = ax.legend(loc="upper center", **kw)
    setattr(leg, BELOW, True)
    return leg
