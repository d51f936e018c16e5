"""What a study's fixed costs leave out changes nothing a user reads: results.parquet holds the
bytes pyarrow.array's columns gave, without pandas' import in the command.

No timing assertions: the costs are held by what is imported and what is computed."""
from __future__ import annotations

import io
import json
import os
import subprocess
import sys
from pathlib import Path

import pyarrow as pa
import pyarrow.parquet as pq

from ballmill.sweep import engine

ROOT = Path(__file__).resolve().parents[1]
ROWS = [
    {"drive.t0": 1.5, "N_max": None, "status": "ok", "valid": True, "point": 3, "message": "x\u00e9\u2713",
     "n": 2, "model": "crank-kernel"},
    {"drive.t0": float("nan"), "N_max": 2, "status": None, "valid": None, "point": 4, "message": "",
     "n": None, "model": None},
    {"drive.t0": float("inf"), "N_max": -0.0, "status": "failed", "valid": False, "point": 5, "message": None,
     "n": -7, "model": 12},
    {"drive.t0": None, "N_max": 1e300, "status": "ok", "valid": True, "point": 6, "message": "a,b\n\"c\"",
     "n": 2 ** 62, "model": "m"},
]
COLS = ["drive.t0", "N_max", "status", "valid", "point", "message", "n", "model", "absent"]
UNITS = {"drive.t0": "s", "N_max": "N"}


def _parquet(table) -> bytes:
    buf = io.BytesIO()
    pq.write_table(table, buf)
    return buf.getvalue()


def test_results_table_is_what_pyarrow_array_made():
    """Every column type (float64 with NaN, infinities and -0.0; int64; bool; string, with str()
    of a non-string), None as null, the units in the fields' metadata: the same Parquet bytes as
    the columns pyarrow.array makes of the same values, for 0, 1 and 4 rows."""
    for k in (0, 1, len(ROWS)):
        rows = ROWS[:k]
        table = engine._table(rows, COLS, UNITS)
        ref = []
        for c, f in zip(COLS, table.schema):
            vals = [r.get(c) for r in rows]
            if f.type == pa.string():
                vals = [None if v is None else str(v) for v in vals]
            elif f.type == pa.float64():
                vals = [None if v is None else float(v) for v in vals]
            ref.append(pa.array(vals, type=f.type))
        assert [f.type for f in table.schema] == ([pa.float64(), pa.float64(), pa.string(), pa.bool_(), pa.int64(),
                                                  pa.string(), pa.int64(), pa.string(), pa.float64()] if k else
                                                 [pa.float64(), pa.float64(), pa.string(), pa.bool_(), pa.int64(),
                                                  pa.string(), pa.float64(), pa.string(), pa.float64()])
        assert table.schema.field("N_max").metadata == {b"unit": b"N"}
        assert _parquet(table) == _parquet(pa.Table.from_arrays(ref, schema=table.schema))


WRITE_SCRIPT = """
import json, sys
from pathlib import Path
from ballmill.sweep import engine
rows, cols, units = json.loads(sys.argv[1])
engine._write(engine._table(rows, cols, units), Path(sys.argv[2]))
print(json.dumps(sorted(m for m in ("pandas",) if m in sys.modules)))
"""


def test_writing_results_does_not_import_pandas(tmp_path):
    """Writing results.parquet loads no pandas (pyarrow.array would, on its first call), and
    the file reads back as the rows."""
    rows = [{k: v for k, v in r.items() if not (isinstance(v, float) and v != v) and v not in (float("inf"),)}
            for r in ROWS]
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")]))
    path = tmp_path / "results.parquet"
    proc = subprocess.run([sys.executable, "-c", WRITE_SCRIPT, json.dumps([rows, COLS, UNITS]), str(path)],
                          capture_output=True, text=True, env=env, cwd=ROOT)
    assert proc.returncode == 0, proc.stderr
    assert json.loads(proc.stdout.strip().splitlines()[-1]) == []
    back = pq.read_table(path).to_pylist()
    assert [r["point"] for r in back] == [3, 4, 5, 6] and back[0]["message"] == "x\u00e9\u2713"
    assert back[2]["model"] == "12" and back[1]["N_max"] == 2.0 and back[3]["n"] == 2 ** 62


def test_maps_after_the_first_keep_its_layout_unless_their_text_would_leave_the_figure(tmp_path, monkeypatch):
    """The heat maps share one figure, laid out for the first; a later map whose colour bar
    carries much wider tick labels and label (six digits with a sign after values below 1, a
    label of three lines after two) is laid out again, so
    that on every PNG everything drawn lies inside the figure; a map whose texts fit
    keeps the first map's axes where they were, also after one laid out again. So each PNG
    depends on its own map and the first only: the maps cut into jobs (one per worker) give
    the same bytes as one job."""
    from ballmill.plotting import figures
    from ballmill.sweep import plots
    from ballmill.sweep.spec import build

    drawn = {}  # PNG -> (the map's axes, everything drawn inside the figure) as last written
    save = figures.save

    def recording(fig, path, dpi=None):
        out = save(fig, path, dpi)
        box = fig.get_tightbbox()  # what the PNG shows: every drawn artist [in]
        w, h = fig.get_size_inches()
        drawn[Path(path).name] = (fig.axes[0].get_position().bounds,
                                  box.x0 >= 0 and box.y0 >= 0 and box.x1 <= w and box.y1 <= h)
        return out

    monkeypatch.setattr(figures, "save", recording)
    t0s, n0s = [1.0, 2.0, 3.0], [60, 70, 80]
    study = build("fast_start", grid={"drive.t0": t0s, "drive.n0": n0s})
    rows = [{"drive.t0": t0, "drive.n0": n0, "status": "ok", "valid": True, "N_range_after": 0.1 * t0,
             "ring_width": 0.2 * t0, "T_drive_peak": -3000.0 * n0 * t0, "E_startup": 0.3 * t0}
            for n0 in n0s for t0 in t0s]
    files = plots.write(study, rows, tmp_path)
    names = ["map_N_range_after.png", "map_ring_width.png", "map_T_drive_peak.png", "map_E_startup.png"]
    assert [f.name for f in files] == names
    assert list(drawn) == [f.name for f in files] and all(inside for _, inside in drawn.values()), drawn
    first = drawn["map_N_range_after.png"][0]
    assert drawn["map_ring_width.png"][0] == first  # its texts fit: the first map's layout
    assert drawn["map_T_drive_peak.png"][0] != first  # laid out again
    assert drawn["map_E_startup.png"][0] == first  # back in the first map's layout
    for parts in (2, 3):
        out = tmp_path / f"parts{parts}"
        out.mkdir()
        jobs = plots.jobs(study, rows, out, parts=parts)
        assert len(jobs) == parts
        assert [f.name for job in jobs for f in job()] == names
        assert all((out / n).read_bytes() == (tmp_path / n).read_bytes() for n in names), parts
