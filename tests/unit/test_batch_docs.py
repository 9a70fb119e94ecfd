"""docs/batch.md: its SLURM example (dask-jobqueue) builds a cluster whose job script is what
the page says; nothing is submitted (no ``cluster.scale``)."""
from __future__ import annotations

import re
from pathlib import Path

DOC = Path(__file__).resolve().parents[2] / "docs" / "batch.md"


def test_slurm_example_builds_the_documented_job():
    block = re.search(r"```python\n(.*?)```", DOC.read_text(), re.S).group(1)
    setup = block.split("cluster.scale(")[0]  # up to the line that would submit jobs
    namespace: dict = {}
    exec(compile(setup, str(DOC), "exec"), namespace)
    cluster = namespace["cluster"]
    try:
        script = cluster.job_script()
    finally:
        cluster.close()
    assert "#SBATCH -p compute" in script and "#SBATCH -A tyre-lab" in script
    assert "#SBATCH --cpus-per-task=1" in script and "#SBATCH -t 04:00:00" in script
    assert "source ~/mfid/.venv/bin/activate" in script
    assert "--nthreads 1" in script  # one single-threaded worker per job
