"""SLURM array jobs: one array task per shard, then one merge.

:func:`sbatch_script` writes a batch script whose array task ``I`` of ``N`` runs
``rfsim sweep run SPEC --shard I/N --resume`` (each shard is a strided subset of the runs,
see :func:`rfsim.sweep.spec.shard_runs`; ``--resume`` lets a requeued task skip the runs
it already finished). All shards write into the same point store, so the output folder
must be on a file system every node sees. After the array job, ``rfsim sweep merge SPEC``
writes the merged file, e.g. as a dependent job::

    jid=$(sbatch --parsable sweep.sbatch)
    sbatch --dependency=afterok:$jid --wrap "rfsim sweep merge SPEC"
"""

from __future__ import annotations

import re
import shlex
import sys
from pathlib import Path

from rfsim.core.errors import UserError


def default_command() -> str:
    """The rfsim command of this installation (the current interpreter's module).

    Returns
    -------
    str
        ``<python> -m rfsim`` with the current interpreter's path, shell-quoted.
    """
    return f"{shlex.quote(sys.executable)} -m rfsim"


#: SLURM --time formats: M, M:S, H:M:S, D-H, D-H:M, D-H:M:S (sbatch(1)), or UNLIMITED.
_TIME = re.compile(r"\d+(?::\d{1,2}){0,2}|\d+-\d{1,2}(?::\d{1,2}){0,2}|UNLIMITED|INFINITE", re.IGNORECASE)
#: A job name that is one word in the script (no spaces, quotes or line breaks).
_JOB_NAME = re.compile(r"[A-Za-z0-9_.+-]{1,128}")
#: SLURM partition (or comma-separated list of partitions) and account names: one word each.
_PARTITION = re.compile(r"[A-Za-z0-9_.+-]{1,128}(,[A-Za-z0-9_.+-]{1,128})*")
_ACCOUNT = re.compile(r"[A-Za-z0-9_.+-]{1,128}")
#: SLURM --mem: a positive integer with an optional unit K, M, G or T (sbatch(1); default M).
_MEM = re.compile(r"[1-9]\d{0,11}[KMGT]?", re.IGNORECASE)
#: Option → (pattern its value must match in full, what it expects: the error message's words).
_OPTION_RULES = {
    "--time": (_TIME, "a SLURM time limit: minutes, MM:SS, HH:MM:SS, D-HH, D-HH:MM or D-HH:MM:SS "
                      "(e.g. 01:30:00)"),
    "--partition": (_PARTITION, "a partition name (letters, digits, _ . + -; several separated by commas)"),
    "--account": (_ACCOUNT, "an account name (1-128 letters, digits or _ . + -)"),
    "--mem": (_MEM, "memory per node as a positive integer with an optional unit K, M, G or T "
                    "(e.g. 4G; no unit: megabytes)"),
}


def _check_option(option: str, text: str) -> str:
    """``text`` unchanged if it matches ``option``'s pattern in :data:`_OPTION_RULES`, else UserError."""
    pattern, expected = _OPTION_RULES[option]
    if not pattern.fullmatch(text):
        raise UserError(f"{option} {text!r}: expected {expected}")
    return text


def check_time_limit(text: str) -> str:
    """Check a SLURM ``--time`` value.

    Parameters
    ----------
    text : str
        The value as given on the command line.

    Returns
    -------
    str
        ``text`` unchanged.

    Raises
    ------
    UserError
        ``text`` is not a SLURM time limit (minutes, ``M:S``, ``H:M:S``, ``D-H``, ``D-H:M``,
        ``D-H:M:S`` or ``UNLIMITED``); the one-line message names ``--time``.
    """
    return _check_option("--time", text)


def check_partition(text: str) -> str:
    """Check a SLURM ``--partition`` value.

    Parameters
    ----------
    text : str
        The value as given on the command line.

    Returns
    -------
    str
        ``text`` unchanged.

    Raises
    ------
    UserError
        ``text`` is not a partition name (letters, digits, ``_ . + -``) or a comma-separated
        list of them; the one-line message names ``--partition``.
    """
    return _check_option("--partition", text)


def check_account(text: str) -> str:
    """Check a SLURM ``--account`` value.

    Parameters
    ----------
    text : str
        The value as given on the command line.

    Returns
    -------
    str
        ``text`` unchanged.

    Raises
    ------
    UserError
        ``text`` is not a SLURM account name; the one-line message names ``--account``.
    """
    return _check_option("--account", text)


def check_memory(text: str) -> str:
    """Check a SLURM ``--mem`` value.

    Parameters
    ----------
    text : str
        The value as given on the command line.

    Returns
    -------
    str
        ``text`` unchanged.

    Raises
    ------
    UserError
        ``text`` is not a positive integer with an optional unit K, M, G or T (none:
        megabytes); the one-line message names ``--mem``.
    """
    return _check_option("--mem", text)


def sbatch_script(spec_path: Path, shards: int, *, workdir: Path, job_name: str = "",
                  cpus_per_task: int = 1, time_limit: str = "", partition: str = "", account: str = "",
                  memory: str = "", output: Path | None = None, command: str | None = None) -> str:
    """Text of an ``sbatch`` array script running ``shards`` shards of the spec.

    Array task ``I`` runs ``rfsim sweep run SPEC --shard I/N --resume`` with
    ``$SLURM_CPUS_PER_TASK`` workers; comment lines give the merge command to run afterwards.

    Parameters
    ----------
    spec_path : pathlib.Path
        The sweep spec (TOML); written into the script as an absolute path.
    shards : int
        Array tasks (shards), >= 1.
    workdir : pathlib.Path
        The jobs' working directory (``#SBATCH --chdir``, as an absolute path).
    job_name : str, optional
        SLURM job name (1-128 letters, digits or ``_ . + -``); default
        ``rfsim-sweep-<spec stem>``.
    cpus_per_task : int, default 1
        ``#SBATCH --cpus-per-task`` (>= 1), and the workers when SLURM does not set it.
    time_limit, partition, account, memory : str, optional
        The ``#SBATCH`` lines ``--time``, ``--partition``, ``--account`` and ``--mem`` (left
        out when empty; each checked by :func:`check_time_limit`, :func:`check_partition`,
        :func:`check_account`, :func:`check_memory`).
    output : pathlib.Path, optional
        The command line's ``--output``, passed on to the run and merge commands as an
        absolute path (default None: the spec's own output).
    command : str, optional
        The rfsim command in the script (default :func:`default_command`).

    Returns
    -------
    str
        The script text, ending with a newline.

    Raises
    ------
    UserError
        ``shards`` or ``cpus_per_task`` < 1, or a bad job name, time limit, partition,
        account or memory (a one-line message naming the option).
    """
    if shards < 1:
        raise UserError(f"--shards {shards}: expected an integer >= 1")
    if cpus_per_task < 1:
        raise UserError(f"--cpus-per-task {cpus_per_task}: expected an integer >= 1")
    given = {"--time": time_limit, "--partition": partition, "--account": account, "--mem": memory}
    for option, value in given.items():
        if value:
            _check_option(option, value)
    if job_name and not _JOB_NAME.fullmatch(job_name):
        raise UserError(f"--job-name {job_name!r}: expected 1-128 letters, digits or _ . + -")
    spec = shlex.quote(str(spec_path.resolve()))
    cmd = command or default_command()
    out_opt = f" --output {shlex.quote(str(output.resolve()))}" if output is not None else ""
    name = job_name or "rfsim-sweep-" + (re.sub(r"[^A-Za-z0-9_.+-]", "_", spec_path.stem) or "spec")
    lines = [
        "#!/bin/bash",
        f"#SBATCH --job-name={name}",
        f"#SBATCH --array=0-{shards - 1}",
        "#SBATCH --ntasks=1",
        f"#SBATCH --cpus-per-task={cpus_per_task}",
        f"#SBATCH --chdir={workdir.resolve()}",
        f"#SBATCH --output={name}-%A_%a.out",
    ]
    lines += [f"#SBATCH {option}={given[option]}" for option in ("--partition", "--account", "--time", "--mem")
              if given[option]]
    lines += [
        "",
        f"# {shards} array tasks; task I runs shard I/{shards} of the sweep into the shared point store.",
        "# When all tasks have finished, merge the shards:",
        f"#   {cmd} sweep merge {spec}{out_opt}",
        "# or submit the merge as a dependent job:",
        "#   jid=$(sbatch --parsable THIS_SCRIPT)",
        f"#   sbatch --dependency=afterok:$jid --wrap \"{cmd} sweep merge {spec}{out_opt}\"",
        "set -euo pipefail",
        f"{cmd} sweep run {spec}{out_opt} --shard \"${{SLURM_ARRAY_TASK_ID}}/{shards}\" "
        f"--workers \"${{SLURM_CPUS_PER_TASK:-{cpus_per_task}}}\" --resume",
        "",
    ]
    return "\n".join(lines)


__all__ = ["sbatch_script", "default_command", "check_time_limit", "check_partition", "check_account",
           "check_memory"]
