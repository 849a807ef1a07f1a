"""spacearm: exact dynamics of free-floating space manipulators (planar and spatial), from Python.

    import spacearm
    model = spacearm.load("models/paper_geared.yaml", params={"p": 10})
    M = model.mass_matrix([0, 0, 0.1, 0.2, 0.3, 0.4])

load() compiles the scene into a shared library through spacearm's compile-and-load cache (or
takes it from there) and returns a Model: every output the scene emits is a method taking numpy
arrays, one state of shape (n,) or k states of shape (k, n).

Study reads a study file (`spacearm sweep`) and computes its runs' CSV rows (Study.rows) or
named numpy columns (Study.table);
spacearm.dask_sweep runs a study on Dask; spacearm.states converts a free base's state to and
from Pinocchio's, SpaceDyn's and SPART's conventions.
"""
try:
    import numpy as _np
except ImportError as e:  # the first python3 on PATH may not be Debian's
    raise ImportError(
        "spacearm needs numpy: run Debian's /usr/bin/python3 (apt-get install python3-numpy), or "
        "create the virtual environment with '/usr/bin/python3 -m venv --system-site-packages'"
    ) from e

from ._spacearm import (
    CompileError,
    DynamicsError,
    IntegrationError,
    Model,
    Study,
    StudyError,
    load,
)

__all__ = [
    "load",
    "Model",
    "Study",
    "DynamicsError",
    "CompileError",
    "IntegrationError",
    "StudyError",
    "write_csv",
]


def write_csv(run, path):
    """Writes the table of a run or plan (the dict Model.simulate, closed_loop and plan return:
    its 'columns', in order) as the CSV `spacearm simulate` and `spacearm plan` write, the same
    bytes (17 significant digits), for `spacearm view PATH --scene SCENE` and any CSV reader."""
    import os
    import stat

    # Written in place (a FIFO or /dev/stdout is written through), but never onto a disk.
    try:
        mode = os.stat(path).st_mode
    except FileNotFoundError:
        mode = 0
    if stat.S_ISBLK(mode) or stat.S_ISDIR(mode):
        kind = "a block device" if stat.S_ISBLK(mode) else "a folder"
        raise ValueError("write_csv: '%s' is %s, not a file to write a CSV into" % (path, kind))
    columns = run["columns"]
    names = list(columns)
    table = _np.column_stack([_np.asarray(columns[n], dtype=float) for n in names])
    with open(path, "w", encoding="ascii", newline="\n") as f:
        f.write(",".join(names) + "\n")
        for row in table:
            f.write(",".join("%.17g" % v for v in row) + "\n")


def _table(self, runs=None, threads=1):
    """The runs' rows (all runs by default) as named columns: 'run' (int), 'status',
    'command_ratio' and 'message' (lists of str), every parameter and metric as a float64
    array (nan where a run failed)."""
    import csv
    import io

    runs = range(self.num_runs) if runs is None else runs
    lines = self.rows(runs, threads=threads)
    reader = csv.reader(io.StringIO(self.header + "".join(lines)))
    names = next(reader)
    rows = list(reader)
    text = {"status", "command_ratio", "message"}
    out = {}
    for c, name in enumerate(names):
        cells = [r[c] for r in rows]
        if name == "run":
            out[name] = _np.array([int(v) for v in cells], dtype=_np.int64)
        elif name in text:
            out[name] = cells
        else:
            out[name] = _np.array([float(v) if v else _np.nan for v in cells])
    return out


Study.table = _table
