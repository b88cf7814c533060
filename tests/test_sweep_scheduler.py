"""``terrasph sweep --scheduler``: before any case, every worker of the cluster writes a probe file
under the sweep directory and the client reads it back; a cluster whose workers write elsewhere
(their own disks: the runs would land there and the manifest point at nothing) is refused in one
line naming the worker, before any case runs. A Dask LocalCluster stands for the cluster; a worker
"on another file system" is one whose probe is made to write into a directory of its own."""

from __future__ import annotations

import logging

import pytest
from terrasph.config import ConfigError

distributed = pytest.importorskip("distributed")

from sweep_helpers import tiny_spec
from terrasph.sweeps.runner import check_shared_output, run_sweep
from terrasph.sweeps.spec import parse_spec


def _own_disk(directory: str) -> None:
    """Run in a worker: its probes write into `directory` (its own disk) whatever they are given."""
    import terrasph.sweeps.runner as runner

    original = runner.probe_output
    runner.probe_output = lambda out_dir, token: original(directory, token)


@pytest.mark.slow  # a two-process cluster: ~6 s of CPU, a minute of wall time on a loaded machine
def test_a_worker_that_does_not_share_the_sweep_directory_is_refused_before_any_case(tmp_path) -> None:
    out = tmp_path / "sweep"
    out.mkdir()
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=":0",
                                  silence_logs=logging.ERROR) as cluster, distributed.Client(cluster) as client:
        address = cluster.scheduler_address
        check_shared_output(client, out, address)  # a shared directory: accepted, its probes removed
        assert not list(out.glob(".probe-*"))
        (tmp_path / "worker-disk").mkdir()
        client.run(_own_disk, str(tmp_path / "worker-disk"), workers=[sorted(client.scheduler_info()["workers"])[0]])
        with pytest.raises(ConfigError, match=r"--scheduler .* wrote .*does not see it.*share"):
            check_shared_output(client, out, address)
        with pytest.raises(ConfigError, match="does not see it"):
            run_sweep(parse_spec(tiny_spec(runs=1)), out, scheduler=address, progress=False)
        assert not list((out / "runs").iterdir())  # refused before any case
