"""Runners for the batch tests: importable by the dask workers (the tests put
this folder on their PYTHONPATH)."""
import os

from ffseg.batch import run_case


def dies_on_case_lost(case, args, out, cli, timeout=None):
    """Ends the worker process itself on case 'lost': a worker lost mid-case."""
    if case == "lost":
        os._exit(3)
    return run_case(case, args, out, cli, timeout)
