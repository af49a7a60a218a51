"""Workspace pavings and pose batches on a Dask cluster (a LocalCluster of two workers in this
process): the same paving and the same answers as serial."""

from __future__ import annotations

import json

import numpy as np
import pinocchio as pin
import pytest

from kinbox import cli
from kinbox.pipeline import IK
from kinbox.workspace import reach

pytest.importorskip("distributed")


@pytest.fixture(scope="module")
def client():
    from distributed import Client, LocalCluster

    cluster = LocalCluster(
        n_workers=2, threads_per_worker=1, processes=False, protocol="tcp", host="127.0.0.1", dashboard_address=None, silence_logs=40
    )
    c = Client(cluster)
    yield c
    c.close()
    cluster.close()


def _same(a, b):
    assert a.complete and b.complete
    assert np.array_equal(a.lo, b.lo) and np.array_equal(a.hi, b.hi) and np.array_equal(a.verdict, b.verdict)
    assert np.array_equal(np.isnan(a.witness), np.isnan(b.witness))


@pytest.mark.parametrize("kw", [{"orientation": (1.0, 0.0, 0.0, 0.0)}, {"orientation": "any"}])
def test_the_paving_is_the_same_on_dask(client, kw):
    region = (0.3, 0.1, 0.2, 0.4, 0.15, 0.25)
    serial = reach("ur5", "tool0", region=region, resolution=0.05, **kw)
    dask = reach("ur5", "tool0", region=region, resolution=0.05, executor=client, **kw)
    _same(serial, dask)
    assert serial.counts()["inside"] > 0


def test_chunks_of_subtrees_cover_them_in_order_and_shrink():
    from kinbox.workspace.remote import chunk_sizes

    for n, slots in [(256, 2), (256, 64), (5, 2), (1, 8), (0, 2)]:
        sizes = chunk_sizes(n, slots, 4)
        assert sum(sizes) == n and sizes == sorted(sizes, reverse=True)
        left = n
        for k in sizes:  # each chunk: the tasks left over four times the threads, rounded up
            assert k == max(1, -(-left // (4 * slots)))
            left -= k
    assert len(chunk_sizes(256, 2, 4)) < 40 and chunk_sizes(256, 2, 4)[-1] == 1


@pytest.mark.parametrize("share", [None, 1])
def test_subtree_tasks_on_dask_pave_as_serial(client, monkeypatch, share):
    from kinbox.workspace import paving, remote

    monkeypatch.setattr(paving, "SUBTREE_TASKS", 4)
    if share is not None:  # chunks of two subtrees, then single ones
        monkeypatch.setattr(remote, "GUIDED_SHARE", share)
    region = (0.6, -0.2, 0.0, 1.0, 0.2, 0.4)
    serial = reach("ur5", "tool0", (1.0, 0.0, 0.0, 0.0), region=region, resolution=0.1)
    dask = reach("ur5", "tool0", (1.0, 0.0, 0.0, 0.0), region=region, resolution=0.1, executor=client)
    assert len(set(serial.verdict.tolist())) > 1
    assert serial.stats["subtrees"] >= 4 and dask.stats["subtrees"] == serial.stats["subtrees"]
    _same(serial, dask)
    assert np.array_equal(serial.witness, dask.witness, equal_nan=True)


def test_poses_on_dask_answer_as_serial(client, tmp_path, capsys):
    ik = IK("ur5", "tool0")
    rng = np.random.default_rng(4)
    lines = []
    for _ in range(3):
        M = ik.pose_at(rng.uniform(-2, 2, 6))
        lines.append(" ".join(f"{v:.17g}" for v in pin.SE3ToXYZQUAT(M)))
    lines.insert(1, "1 2 3")  # a bad line: its own error record
    f = tmp_path / "poses.txt"
    f.write_text("\n".join(lines) + "\n")
    argv = ["ik", "ur5", "--frame", "tool0", "--poses", str(f), "--json", "--quiet"]
    assert cli.main(argv) == 5
    serial = [json.loads(x) for x in capsys.readouterr().out.splitlines()]
    assert cli.main([*argv, "--dask", client.scheduler.address]) == 5
    dask = [json.loads(x) for x in capsys.readouterr().out.splitlines()]
    assert len(serial) == len(dask) == 4
    for a, b in zip(serial, dask):
        if "error" in a:
            assert a == b
            continue
        assert a["complete"] == b["complete"] and len(a["solutions"]) == len(b["solutions"]) > 0
        qa = sorted(tuple(np.round(s["q"], 6)) for s in a["solutions"])
        qb = sorted(tuple(np.round(s["q"], 6)) for s in b["solutions"])
        assert qa == qb


def test_the_command_paves_on_dask_as_serial(client, tmp_path):
    from kinbox.workspace import Paving

    argv = ["reach", "ur5", "--frame", "tool0", "--any-orientation", "--quiet", "--resolution", "0.05"]
    argv += ["--region", "0.3", "0.1", "0.2", "0.4", "0.15", "0.25"]
    assert cli.main([*argv, "--out", str(tmp_path / "s.npz")]) == 0
    assert cli.main([*argv, "--dask", client.scheduler.address, "--out", str(tmp_path / "d.npz")]) == 0
    _same(Paving.load(str(tmp_path / "s.npz")), Paving.load(str(tmp_path / "d.npz")))
