"""spacearm.Study and spacearm.dask_sweep: the same study run by `spacearm sweep` in two shards,
by Study.rows on threads and by Dask on a LocalCluster of two worker processes gives the same
results.csv bytes (about 10 s, most of it Dask's start)."""
import os
import subprocess

import numpy as np
import pytest

import spacearm

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
CACHE = os.environ.get("SPACEARM_TEST_CACHE_DIR", "")
STUDY = """scene: {scene}
manoeuvre:
  plan: {{from: [1.5, 0.0, 0.5235987755982988], to: [1.45, 0.02, 0.55], duration: 1}}
integrator: {{method: rk4, dt: 0.01}}
grid:
  p: [1, 2, 3]
random:
  runs: 3
  seed: 11
  draws:
    Im: {{log_uniform: [1.0e-6, 1.0e-3]}}
"""


@pytest.fixture
def study_path(tmp_path):
    path = tmp_path / "study.yaml"
    path.write_text(STUDY.format(scene=os.path.join(ROOT, "models", "paper_geared.yaml")))
    return str(path)


def cli_results(study_path, out):
    cli = os.environ.get("SPACEARM_CLI")
    if not cli:
        pytest.skip("SPACEARM_CLI (the spacearm program) is set by ctest")
    for shard in ("1/2", "2/2"):
        subprocess.run([cli, "sweep", study_path, "-o", str(out), "--shard", shard,
                        "--cache-dir", CACHE], check=True, capture_output=True)
    return (out / "results.csv").read_bytes()


def test_threads_shards_and_dask_give_the_same_bytes(study_path, tmp_path):
    from dask.distributed import Client, LocalCluster
    from spacearm.dask_sweep import run_study

    expected = cli_results(study_path, tmp_path / "cli")
    study = spacearm.Study(study_path, CACHE)
    assert study.num_runs == 9
    rows = study.rows(reversed(range(9)), threads=2)
    assert study.merge(rows).encode() == expected
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                      dashboard_address=None) as cluster, Client(cluster) as client:
        path = run_study(client, study_path, str(tmp_path / "dask"), chunk=2, cache_dir=CACHE)
    assert open(path, "rb").read() == expected
    assert len(set(expected.decode().splitlines())) == 10  # header and 9 different runs


def test_study_errors_are_python_exceptions(study_path, tmp_path):
    with pytest.raises(spacearm.StudyError, match="cannot open"):
        spacearm.Study(str(tmp_path / "missing.yaml"), CACHE)
    bad = tmp_path / "bad.yaml"
    bad.write_text(open(study_path).read().replace("p: [1, 2, 3]", "mass: [1]"))
    with pytest.raises(spacearm.StudyError, match="field 'grid.mass'"):
        spacearm.Study(str(bad), CACHE)
    study = spacearm.Study(study_path, CACHE)
    with pytest.raises(IndexError, match="runs 0 .. 8"):
        study.rows([9])
    with pytest.raises(TypeError, match="runs: run indices are integers, not float"):
        study.rows([1.5])
    assert study.rows([np.int64(1)]) == study.rows([1])
    with pytest.raises(spacearm.StudyError, match="run 3 has no row"):
        study.merge(study.rows([0, 1, 2]))
    assert list(study.parameters(4)[:1]) == [2.0]
    assert "9 runs of scene paper_geared" in repr(study)


def test_study_table_is_named_numpy_columns(study_path):
    """Study.table (issue 29): the rows as named columns, numbers as float64 arrays."""
    study = spacearm.Study(study_path, cache_dir=CACHE)
    table = study.table(threads=2)
    header = study.header.strip().split(",")
    assert list(table) == header and len(table["run"]) == study.num_runs == 9
    assert table["run"].dtype == np.int64 and list(table["run"]) == list(range(9))
    assert table["status"] == ["ok"] * 9 and table["command_ratio"] == ["run"] * 9
    assert np.array_equal(table["p"], np.repeat([1.0, 2.0, 3.0], 3))
    row = study.rows([4])[0].split(",")  # the same numbers as the CSV row
    for c, name in enumerate(header[2:-2], start=2):
        assert table[name][4] == float(row[c]), name



def test_a_spatial_study_is_a_table_of_3d_rows():
    """A study of the 3D arm (issue 31, studies/space_arm7_payload.yaml): the rows carry the 3D
    pose and its errors; the nominal run (p = 100, 0.5 kg) ends at the plan's goal (about 2 s,
    the model compiled once or found in the cache)."""
    study = spacearm.Study(os.path.join(ROOT, "studies", "space_arm7_payload.yaml"), CACHE)
    assert study.num_runs == 8 and "8 runs of scene space_arm7_payload" in repr(study)
    table = study.table(runs=[1, 7], threads=2)
    for name in ("ee_z", "ee_qw", "ee_angle_error", "base_rotation", "momentum_drift"):
        assert name in table, name
    assert table["status"] == ["ok", "ok"]
    assert list(table["p"]) == [100.0, 100.0] and list(table["mp"]) == [0.5, 20.0]
    assert table["ee_error"][0] < 3e-5 and table["ee_angle_error"][0] < 1e-5
    assert table["ee_error"][1] > 0.05  # 20 kg the plan did not know
    quaternion = np.array([table[c] for c in ("ee_qw", "ee_qx", "ee_qy", "ee_qz")])
    assert np.allclose(np.linalg.norm(quaternion, axis=0), 1, atol=1e-9)
