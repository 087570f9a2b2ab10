"""A LocalCluster of two worker processes on loopback, for the tests: prints its address, lives until stdin closes.

Run in a process of its own, so that Dask's threads and memory stay out of the test process
(whose forked grading workers would inherit them, under their memory limit).
"""

import sys

import dask
import distributed

if __name__ == "__main__":
    with dask.config.set({"distributed.worker.daemon": False}):  # the job starts a process per submission
        with distributed.LocalCluster(
            n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1", dashboard_address=None
        ) as cluster:
            print(cluster.scheduler_address, flush=True)
            sys.stdin.read()
