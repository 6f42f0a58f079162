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

import shlex
import sys
from pathlib import Path

from rfsim.errors import UserError


def default_command() -> str:
    """The rfsim command of this installation (the current interpreter's module)."""
    return f"{shlex.quote(sys.executable)} -m rfsim"


def sbatch_script(spec_path: Path, shards: int, *, workdir: Path, job_name: str = "",
                  cpus_per_task: int = 1, time_limit: str = "", command: str | None = None) -> str:
    """Text of an ``sbatch`` array script running ``shards`` shards of the spec."""
    if shards < 1:
        raise UserError(f"--shards {shards}: expected an integer >= 1")
    if cpus_per_task < 1:
        raise UserError(f"--cpus-per-task {cpus_per_task}: expected an integer >= 1")
    spec = shlex.quote(str(spec_path.resolve()))
    cmd = command or default_command()
    name = job_name or f"rfsim-sweep-{spec_path.stem}"
    lines = [
        "#!/bin/bash",
        f"#SBATCH --job-name={name}",
        f"#SBATCH --array=0-{shards - 1}",
        "#SBATCH --ntasks=1",
        f"#SBATCH --cpus-per-task={cpus_per_task}",
        f"#SBATCH --chdir={workdir.resolve()}",
        f"#SBATCH --output={name}-%A_%a.out",
    ]
    if time_limit:
        lines.append(f"#SBATCH --time={time_limit}")
    lines += [
        "",
        f"# {shards} array tasks; task I runs shard I/{shards} of the sweep into the shared point store.",
        "# When all tasks have finished, merge the shards:",
        f"#   {cmd} sweep merge {spec}",
        "# or submit the merge as a dependent job:",
        "#   jid=$(sbatch --parsable THIS_SCRIPT)",
        f"#   sbatch --dependency=afterok:$jid --wrap \"{cmd} sweep merge {spec}\"",
        "set -euo pipefail",
        f"{cmd} sweep run {spec} --shard \"${{SLURM_ARRAY_TASK_ID}}/{shards}\" "
        f"--workers \"${{SLURM_CPUS_PER_TASK:-{cpus_per_task}}}\" --resume",
        "",
    ]
    return "\n".join(lines)


__all__ = ["sbatch_script", "default_command"]
