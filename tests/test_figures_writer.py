"""Writing a run's files costs little and changes nothing a user reads: results.csv is what
numpy.savetxt(fmt="%.12g") wrote, byte for byte, special values included; figures.Writer's PNGs
(drawn in forked processes, side by side) have the pixels of a figure saved in the command, each
as the figure stood when saved, and a failed drawing is an error naming the file."""
from __future__ import annotations

import io
import types

import numpy as np
import pytest
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
    for rows in (data, data[:0]):
        res.data = rows
        report.write_csv(res, tmp_path / "r.csv")
        want = io.BytesIO()
        np.savetxt(want, rows, delimiter=",", header=",".join(res.columns), comments="", fmt="%.12g")
        assert (tmp_path / "r.csv").read_bytes() == want.getvalue()


def _pixels(path):
    with Image.open(path) as im:
        return np.asarray(im.convert("RGB"))


def test_writer_draws_each_figure_as_it_stood_and_names_a_failure(tmp_path):
    fig, ax = figures.subplots(figsize=(4.0, 3.0), dpi=50, layout="tight")
    ax.plot([0, 1, 2], [0, 1, 0])
    with figures.Writer(jobs=2) as w:
        assert w.fork  # this machine forks: the second figure takes the forked path
        for title in ("first", "second"):
            ax.set_title(title)
            w.save(fig, tmp_path / f"{title}.png")
    for title in ("first", "second"):
        ax.set_title(title)
        figures.save(fig, tmp_path / f"{title}_inline.png")
        assert np.array_equal(_pixels(tmp_path / f"{title}.png"), _pixels(tmp_path / f"{title}_inline.png"))
    assert not np.array_equal(_pixels(tmp_path / "first.png"), _pixels(tmp_path / "second.png"))
    bad = tmp_path / "missing" / "x.png"
    with pytest.raises(RuntimeError, match=f"{bad} \\(exit status 1\\)"):
        with figures.Writer(jobs=2) as w:
            w.save(fig, tmp_path / "fine.png")  # the first: drawn in this process
            w.save(fig, bad)  # forked: its failure is reported by wait
    assert (tmp_path / "fine.png").exists()
