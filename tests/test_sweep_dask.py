"""Sweeps on Dask: a LocalCluster (loopback only) gives the serial bits, also when one
worker process is SIGKILLed mid-sweep. Skipped when dask.distributed is not installed."""

from __future__ import annotations

import os
import signal

import pytest

from rfsim.core.errors import UserError
from rfsim.sweep import DaskExecutor, SerialExecutor, load_spec, run_sweep
from rfsim.sweep.executors import parse_dask_target
from test_sweep_run import assert_identical, write_spec

distributed = pytest.importorskip("dask.distributed")


@pytest.fixture(scope="module")
def client():
    cluster = distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                       host="127.0.0.1", dashboard_address="127.0.0.1:0", silence_logs=50)
    c = distributed.Client(cluster)
    yield c
    c.close()
    cluster.close()


def test_parse_dask_target():
    assert parse_dask_target("local") == ("local", None)
    assert parse_dask_target("local:3") == ("local", 3)
    assert parse_dask_target("tcp://10.0.0.1:8786") == ("tcp://10.0.0.1:8786", None)
    with pytest.raises(UserError, match="local:N"):
        parse_dask_target("local:x")


def test_dask_local_cluster_is_bit_identical_to_serial(client, tmp_path):
    (tmp_path / "a").mkdir()
    (tmp_path / "b").mkdir()
    serial = run_sweep(load_spec(write_spec(tmp_path / "a", "s")), SerialExecutor())
    executor = DaskExecutor(client)
    assert executor.workers == 2
    report = run_sweep(load_spec(write_spec(tmp_path / "b", "s")), executor)
    assert report.computed == 12
    assert len({r.pid for r in report.results}) == 2  # both workers ran points
    assert assert_identical(serial.output, report.output) > 20


def test_killing_a_dask_worker_mid_sweep_still_completes_identically(client, tmp_path):
    (tmp_path / "a").mkdir()
    (tmp_path / "b").mkdir()
    kw = dict(q=tuple(range(6)), profiles=("fm0-40k",), fs_hz=4e6)  # 24 runs of ~20 ms
    serial = run_sweep(load_spec(write_spec(tmp_path / "a", "s", **kw)), SerialExecutor())
    pids = client.run(os.getpid)
    victim = sorted(pids.values())[0]
    killed = []

    def kill_one_worker(result):  # at the first finished run, the victim is busy with another
        if not killed:
            os.kill(victim, signal.SIGKILL)
            killed.append(victim)

    report = run_sweep(load_spec(write_spec(tmp_path / "b", "s", **kw)), DaskExecutor(client),
                       on_result=kill_one_worker)
    assert killed == [victim]
    assert report.computed == 24 and len({(r.point, r.repetition) for r in report.results}) == 24
    assert victim not in client.run(os.getpid).values()  # the nanny started a new worker
    assert_identical(serial.output, report.output)


def test_cli_dask_local_cluster(tmp_path, monkeypatch, capsys):
    from rfsim.cli import main

    monkeypatch.chdir(tmp_path)
    spec = write_spec(tmp_path, "s", q=(1,))
    assert main(["sweep", str(spec), "--dask", "local:1"]) == 0
    out = capsys.readouterr().out
    assert "4 runs, 4 computed, 0 reused" in out and "on dask (1 worker)" in out
    assert (tmp_path / "s.h5").exists()
    assert main(["sweep", str(spec), "--dask", "local:0"]) == 2
    assert "local:N with N >= 1" in capsys.readouterr().err


def test_dask_scheduler_address(client, tmp_path):
    """--dask ADDRESS connects a new client to a running scheduler and leaves it running."""
    executor = DaskExecutor(client.scheduler.address)
    try:
        assert executor.workers == 2 and executor.client is not client
        report = run_sweep(load_spec(write_spec(tmp_path, "s", q=(1,))), executor)
    finally:
        executor.close()
    assert report.computed == 4 and report.output.exists()
    assert len(client.run(os.getpid)) == 2  # the cluster is still up
