#!/usr/bin/python3
"""Runs a study (`spacearm sweep`'s file) on Dask and writes OUT/results.csv, the same bytes as
`spacearm sweep STUDY -o OUT`.

    PYTHONPATH=build/python /usr/bin/python3 examples/dask_sweep.py studies/paper_gear_ratio.yaml out/dask
    ... --scheduler tcp://scheduler:8786     # a running Dask cluster instead of a LocalCluster

Without --scheduler it starts a LocalCluster of --workers processes (one thread each).
"""
import argparse
import sys
import time

from dask.distributed import Client, LocalCluster

import spacearm
from spacearm.dask_sweep import run_study


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("study", help="study file (YAML)")
    parser.add_argument("out", help="results folder")
    parser.add_argument("--scheduler", help="address of a Dask scheduler (default: a LocalCluster)")
    parser.add_argument("--workers", type=int, default=2, help="LocalCluster worker processes")
    parser.add_argument("--chunk", type=int, default=64, help="runs per Dask task")
    parser.add_argument("--cache-dir", default="", help="compiled-model cache (shared by workers)")
    args = parser.parse_args()
    if args.workers < 1 or args.chunk < 1:
        parser.error("--workers and --chunk must be at least 1")
    start = time.time()
    try:
        if args.scheduler:
            with Client(args.scheduler) as client:
                path = run_study(client, args.study, args.out, args.chunk, args.cache_dir)
        else:
            with LocalCluster(n_workers=args.workers, threads_per_worker=1,
                              dashboard_address=None) as cluster, Client(cluster) as client:
                path = run_study(client, args.study, args.out, args.chunk, args.cache_dir)
    except (spacearm.StudyError, spacearm.CompileError, OSError) as e:
        sys.exit("dask_sweep: error: %s" % e)
    print("dask_sweep: wrote %s in %.1f s" % (path, time.time() - start))


if __name__ == "__main__":
    main()
