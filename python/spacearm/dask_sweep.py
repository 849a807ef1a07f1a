"""A study's runs on Dask (dask.distributed): the same rows and results.csv as `spacearm sweep`.

    from dask.distributed import Client, LocalCluster
    from spacearm.dask_sweep import run_study
    with LocalCluster(n_workers=4, threads_per_worker=1) as cluster, Client(cluster) as client:
        run_study(client, "studies/paper_gear_ratio.yaml", "results/")

Dask schedules chunks of run indices on its workers; each worker process opens the study once
(the compile-and-load cache: on a cluster, give a cache_dir on a shared file system, or let each
machine compile once) and returns the chunk's CSV rows; the client merges them into
results.csv, sorted by run. No scheduling of our own: Dask's does it all, on one machine or on a
cluster (Client("tcp://scheduler:8786")). Unlike `spacearm sweep` it keeps no rows before the
end (a killed run starts over) and writes no per-run time series.
"""
import functools
import os

from ._spacearm import Study


@functools.lru_cache(maxsize=4)
def _study(path, cache_dir):
    return Study(path, cache_dir)


def study_rows(path, cache_dir, runs):
    """The rows of some runs of a study: the function Dask maps over chunks of runs."""
    return _study(path, cache_dir).rows(list(runs))


def run_study(client, path, out_dir, chunk=64, cache_dir=""):
    """Runs every run of the study at `path` on the Dask client's workers and writes
    out_dir/results.csv; returns its path. chunk: runs per task (a few ms each)."""
    path = os.path.abspath(path)
    study = _study(path, cache_dir)  # also checks the study here, before any task runs
    if study.time_series:
        raise ValueError("run_study writes results.csv only: run `spacearm sweep` for a study "
                         "with time_series")
    # The folder is checked (yours, nothing planted, not another study's) before any task runs.
    study.claim_folder(out_dir)
    chunks = [range(a, min(a + chunk, study.num_runs)) for a in range(0, study.num_runs, chunk)]
    futures = client.map(study_rows, [path] * len(chunks), [cache_dir] * len(chunks), chunks,
                         pure=False)
    rows = [row for part in client.gather(futures) for row in part]
    return study.write_results(out_dir, rows)
