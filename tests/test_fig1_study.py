"""The Fig. 1 study's measures (ballmill/studies/fig1.py): equal-area cells, the visited
fraction, the first-failure time; and the study writing its page from a coarse run."""
import math

import numpy as np
import pytest

from ballmill.studies import fig1


def _uniform_sphere(count, seed):
    u = np.random.default_rng(seed).normal(size=(count, 3))
    return u / np.linalg.norm(u, axis=1)[:, None]


def test_cells_have_equal_area():
    """Uniform points on the sphere fall evenly into the cells: with 400 points a cell on
    average the counts' relative spread is 1/sqrt(400) = 0.05; unequal cells (bands of
    equal latitude instead of equal height) would spread them by ~0.5."""
    u = _uniform_sphere(400 * fig1.N_CELLS, 1)
    counts = np.bincount(fig1.cells(u), minlength=fig1.N_CELLS)
    assert counts.size == fig1.N_CELLS
    spread = counts.std() / counts.mean()
    assert spread < 0.06
    # equal latitude bands (the wrong measure) for comparison
    lat = np.clip(((np.arcsin(u[:, 2]) / math.pi + 0.5) * fig1.N_BANDS).astype(int), 0, fig1.N_BANDS - 1)
    wrong = np.bincount(lat * fig1.N_SECTORS + fig1.cells(u) % fig1.N_SECTORS, minlength=fig1.N_CELLS)
    assert wrong.std() / wrong.mean() > 0.3


def test_visited_fraction():
    assert fig1.visited_fraction(_uniform_sphere(200000, 2)) == 1.0
    ring = np.column_stack([np.cos(np.linspace(0, 2 * np.pi, 5000)), np.sin(np.linspace(0, 2 * np.pi, 5000)),
                            np.zeros(5000) + 1e-9])  # the equator: one band of sectors
    assert fig1.visited_fraction(ring) == pytest.approx(fig1.N_SECTORS / fig1.N_CELLS)
    curve = fig1.visited_curve(ring)
    assert curve[-1] == fig1.visited_fraction(ring) and np.all(np.diff(curve) >= 0)


def test_first_failure_interpolates():
    t = np.array([0.0, 1.0, 2.0, 3.0])
    assert fig1.first_failure(t, np.array([3.0, 1.0, -1.0, 2.0])) == pytest.approx(1.5)
    assert fig1.first_failure(t, np.array([1.0, 1.0, 1.0, 1.0])) is None
    assert fig1.first_failure(t, np.array([0.0, 1.0, 1.0, 1.0])) == 0.0


def test_study_writes_its_page(tmp_path):
    """A coarse run (dt = 0.01 s) through main: page, figures, CSV; the Fig. 1 machine's
    first slip lands where the fine run puts it (2.508 s) to within the coarse grid's
    interpolation (measured 2.5082 s at dt = 0.01); the energy balance holds to the
    quadrature error of Simpson on the 10 ms grid (measured 7e-6 of the energy swing)."""
    doc, figs, csv = tmp_path / "fig1.md", tmp_path / "figs", tmp_path / "csv"
    assert fig1.main(["--dt", "0.01", "--doc", str(doc), "--figures", str(figs), "--csv", str(csv)]) == 0
    text = doc.read_text()
    assert "rolling first fails" in text and "fig1_machine" in text
    assert (figs / "fig1_paths.png").stat().st_size > 10000 and (figs / "fig1_signals.png").stat().st_size > 10000
    data = np.genfromtxt(csv / "fig1_machine.csv", delimiter=",", names=True)
    assert data["time"][-1] == pytest.approx(10.0) and "M2" in data.dtype.names
    motion, tr = fig1.run("fig1_machine", 0.01)
    m = fig1.metrics("fig1_machine", motion, tr)
    assert m["t_slip"] == pytest.approx(2.508, abs=0.003)
    assert m["t_contact"] == pytest.approx(2.585, abs=0.003)
    assert abs(m["dE"] - m["work"]) <= 5e-5 * m["E_swing"]
