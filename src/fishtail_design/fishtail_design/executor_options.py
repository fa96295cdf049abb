"""The command line's choice of executor: --processes, --workers, --scheduler, --batch-size.

:func:`add_executor_arguments` adds the options and :func:`executor_from_arguments` builds the
executor they name (:mod:`~fishtail_design.executors`, or
:class:`~fishtail_design.dask_executor.DaskExecutor`). docs/design.md, "Scaling out".
"""

from __future__ import annotations

import argparse
from urllib.parse import urlsplit

from fishtail_common.command_line import add_parameter_options
from fishtail_common.parameters import ParameterSpec
from fishtail_design.executors import (
    BATCH_SIZE,
    Executor,
    InProcessExecutor,
    LocalProcessExecutor,
)

PROCESSES = ParameterSpec("processes", 2, "evaluate in N local processes", "", 1, 1024)
WORKERS = ParameterSpec(
    "workers", 2, "start a local Dask cluster of N single-threaded worker processes", "", 1, 1024
)
BATCH_SIZE_OPTION = ParameterSpec(
    "batch_size",
    BATCH_SIZE,
    "most designs per task: larger batches cost less overhead, smaller ones keep more workers busy",
    "",
    1,
    1_000_000,
)


def add_executor_arguments(parser: argparse.ArgumentParser) -> None:
    """``--processes N``, ``--workers N`` or ``--scheduler tcp://HOST:PORT``, and ``--batch-size``.

    The first three are mutually exclusive (none: in this process); values out of range are
    argparse errors. :func:`executor_from_arguments` builds the executor they name.
    """
    group = parser.add_argument_group(
        "where the designs are evaluated (default: in this process)",
        "A Dask cluster's workers need the same fishtail install as this machine; "
        "docs/design.md, Scaling out.",
    )
    where = group.add_mutually_exclusive_group()
    add_parameter_options(where, [PROCESSES, WORKERS], optional=True)
    where.add_argument(
        "--scheduler",
        type=scheduler_address,
        metavar="tcp://HOST:PORT",
        help="evaluate on the running Dask cluster whose scheduler is there",
    )
    add_parameter_options(group, [BATCH_SIZE_OPTION])


def scheduler_address(text: str) -> str:
    """A Dask scheduler's address, ``tcp://HOST:PORT``, as argparse checks it.

    Raises:
        argparse.ArgumentTypeError: another form.

    >>> scheduler_address("tcp://10.0.0.5:8786")
    'tcp://10.0.0.5:8786'
    """
    try:
        parts = urlsplit(text)
        port = parts.port
    except ValueError:
        port = None
    else:
        if parts.scheme == "tcp" and parts.hostname and port and not (parts.path or parts.query):
            return text
    raise argparse.ArgumentTypeError(f"expected tcp://HOST:PORT, got {text!r}")


def executor_from_arguments(arguments: argparse.Namespace) -> Executor:
    """The executor that :func:`add_executor_arguments`'s options name.

    Raises:
        ExecutorError: a Dask cluster that does not start or a scheduler that does not answer.
    """
    if arguments.processes is not None:
        return LocalProcessExecutor(arguments.processes)
    # Dask's module is imported only for a run that asks for it (its import takes seconds).
    from fishtail_design.dask_executor import DaskExecutor

    if arguments.workers is not None:
        return DaskExecutor(workers=arguments.workers)
    if arguments.scheduler is not None:
        return DaskExecutor(arguments.scheduler)
    return InProcessExecutor()
