"""A LocalCluster of two worker processes on loopback, for the tests: prints its address, lives until stdin closes.

With the argument ``daemon``, its workers are as Dask makes them by default: daemons.

Run in a process of its own, so that Dask's threads and memory stay out of the test process
(whose forked grading workers would inherit them, under their memory limit).
"""

import sys

import dask
import distributed

if __name__ == "__main__":
    # "daemon": Dask's own default, workers that run as daemons (they grade through a process of their own);
    # else workers that are not, which start a submission's process themselves
    settings = {} if sys.argv[1:] == ["daemon"] else {"distributed.worker.daemon": False}
    with dask.config.set(settings):
        with distributed.LocalCluster(
            n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1", dashboard_address=None
        ) as cluster:
            print(cluster.scheduler_address, flush=True)
            sys.stdin.read()
