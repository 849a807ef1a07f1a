"""spacearm: exact dynamics of planar free-floating space manipulators, from Python.

    import spacearm
    model = spacearm.load("models/paper_geared.yaml", params={"p": 10})
    M = model.mass_matrix([0, 0, 0.1, 0.2, 0.3, 0.4])

load() compiles the scene into a shared library through spacearm's compile-and-load cache (or
takes it from there) and returns a Model: every output the scene emits is a method taking numpy
arrays, one state of shape (n,) or k states of shape (k, n).

Study reads a study file (`spacearm sweep`) and computes its runs' CSV rows;
spacearm.dask_sweep runs a study on Dask.
"""
from ._spacearm import CompileError, DynamicsError, Model, Study, StudyError, load

__all__ = ["load", "Model", "Study", "DynamicsError", "CompileError", "StudyError"]
