"""Writing a run's files costs little and changes nothing a user reads: results.csv is what
numpy.savetxt(fmt="%.12g") wrote, byte for byte, special values included; an opaque figure's PNG
is encoded as RGB with exactly the pixels the canvas drew."""
from __future__ import annotations

import io
import types

import numpy as np
from PIL import Image

from ballmill.plotting import figures
from ballmill.scenario import report


def test_results_csv_is_what_savetxt_wrote(tmp_path):
    rng = np.random.default_rng(1)
    data = rng.normal(size=(7, 4)) * 10.0 ** rng.integers(-30, 30, size=(7, 4))
    data[0] = [np.nan, np.inf, -np.inf, -0.0]
    data[1] = [1e300, 5e-324, 123456789012345678.0, 1.0 / 3.0]
    data[2] = [0.0, 1.0, -2.5, 1e-5]
    res = types.SimpleNamespace(columns=["time", "a.x", "a.y", "b.z"], data=data)
    steady = np.array([[-0.0, np.nan, 1e300, 2.0 / 3.0]] * 5)  # columns of one value (-0.0 is not 0.0)
    steady[1:, 0] = 0.0
    for rows in (data, data[:0], steady, np.column_stack([data[:, 0], np.full(7, np.inf), data[:, 2], data[:, 2]])):
        res.data = rows
        report.write_csv(res, tmp_path / "r.csv")
        want = io.BytesIO()
        np.savetxt(want, rows, delimiter=",", header=",".join(res.columns), comments="", fmt="%.12g")
        assert (tmp_path / "r.csv").read_bytes() == want.getvalue()


def test_an_opaque_figure_is_written_as_rgb_with_the_canvas_pixels(tmp_path):
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    fig, ax = figures.subplots(figsize=(4.0, 3.0), dpi=50, layout="tight")
    ax.plot([0, 1, 2], [0, 1, 0])
    ax.set_title("opaque")
    path = figures.save(fig, tmp_path / "f.png")
    drawn = np.asarray(fig.canvas.buffer_rgba())  # what save drew (fig's own Agg canvas), not drawn again
    assert isinstance(fig.canvas, FigureCanvasAgg)
    with Image.open(path) as im:
        assert im.mode == "RGB" and im.size == (drawn.shape[1], drawn.shape[0])
        assert np.array_equal(np.asarray(im), drawn[..., :3]) and drawn[..., 3].min() == 255
    fig.patch.set_alpha(0.5)  # a translucent one keeps its alpha channel
    with Image.open(figures.save(fig, tmp_path / "t.png")) as im:
        drawn = np.asarray(fig.canvas.buffer_rgba())
        assert im.mode == "RGBA" and np.array_equal(np.asarray(im), drawn) and drawn[..., 3].min() < 255
        assert im.info["Software"] == "matplotlib (ballmill.plotting.figures)"
