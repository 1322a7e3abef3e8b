"""The host-sync audit (`tests/sync_audit.py`) sees what it must see, so an audit that finds
nothing means something."""

import numpy as np
import pytest
import torch

from tests.sync_audit import SyncAudit, host_state

X = torch.arange(12.0).reshape(3, 4)


@pytest.mark.parametrize("name, operation, kind", [
    ("item", lambda: X.sum().item(), "scalar read"),
    ("float", lambda: float(X[0, 1]), "scalar read"),
    ("bool", lambda: bool((X > 3).any()), "scalar read"),
    ("cpu", lambda: X.cpu(), "cpu"),
    ("tolist", lambda: X[0].tolist(), "tolist"),
    ("numpy", lambda: X.numpy(), "numpy"),
    ("nonzero", lambda: X.nonzero(), "aten.nonzero.default"),
    ("boolean-mask read", lambda: X[X > 3], "boolean mask"),
    ("boolean-mask write", lambda: X.clone().__setitem__(X > 3, 0.0), "boolean mask"),
    ("numpy rows", lambda: X[np.array([0, 2])], "index from host data"),
    ("list of columns", lambda: X[:, [1, 3]], "index from host data"),
])
def test_each_kind_of_sync_is_counted(name, operation, kind):
    with SyncAudit() as audit:
        operation()
    assert [what for what, _ in audit.events] == [kind], name


@pytest.mark.parametrize("name, operation", [
    ("item", lambda: X.sum().item()),
    ("float", lambda: float(X[0, 1])),
    ("int", lambda: int(X.max())),
    ("bool", lambda: bool((X > 3).any())),
])
def test_scalar_reads_are_counted_under_inference_mode_too(name, operation):
    """Scoring runs under `torch.inference_mode`, where these reach the dispatcher as `item` or
    `is_nonzero` rather than `_local_scalar_dense`: each still counts once."""
    with SyncAudit() as audit, torch.inference_mode():
        operation()
    assert [what for what, _ in audit.events] == ["scalar read"], name


def test_device_side_work_is_not_counted_and_every_op_is_listed():
    rows = torch.tensor([0, 2])  # made before: on the device in a CUDA run
    with SyncAudit() as audit:
        y = X[rows] * 2  # an index tensor on the device
        y[:, 1:] = 0.0  # a slice write
        torch.where(y > 3, y, torch.zeros_like(y)).sum()
        torch.stack([X[:, 1], X[:, 3]], dim=1)
    assert audit.events == []
    assert audit.ops["aten.index.Tensor"] == 1 and audit.ops["aten.sum.default"] == 1


def test_reads_of_host_tensors_and_of_what_is_computed_from_them_alone_are_free():
    model = torch.nn.Linear(2, 1)
    optimizer = torch.optim.Adam(model.parameters())
    model(torch.ones(1, 2)).sum().backward()
    optimizer.step()  # creates Adam's step counts
    assert len(host_state(optimizer)) == 2
    with SyncAudit(host_state(optimizer)) as audit:
        model(torch.ones(1, 2)).sum().backward()
        optimizer.step()  # reads its step counts on the host
    assert audit.events == []
    with SyncAudit() as audit:  # without them, the same step reads two "device" scalars
        optimizer.step()
    assert [what for what, _ in audit.events] == ["scalar read"] * 2
    step = host_state(optimizer)[0]
    with SyncAudit([step]) as audit:
        bool(step > 1)  # from the host tensor alone: free
        (step * model.weight).sum().item()  # mixed with a device tensor: a sync
    assert [what for what, _ in audit.events] == ["scalar read"]


INDEX = torch.tensor([0, 2, 2])
VALUES = torch.tensor([1.0, 2.0, 3.0])


@pytest.mark.parametrize("name, operation", [
    ("scatter_add_", lambda: torch.zeros(3).scatter_add_(0, INDEX, VALUES)),
    ("scatter of a tensor", lambda: torch.zeros(3).scatter(0, INDEX, VALUES)),
    ("scatter_reduce sum", lambda: torch.zeros(3).scatter_reduce(0, INDEX, VALUES, "sum")),
    ("index_add_", lambda: torch.zeros(3).index_add_(0, INDEX, VALUES)),
    ("index_put_ accumulating", lambda: torch.zeros(3).index_put_((INDEX,), VALUES, accumulate=True)),
    ("a tensor-indexed write", lambda: torch.zeros(3).__setitem__(INDEX, VALUES)),
    ("index_copy_", lambda: torch.zeros(3).index_copy_(0, torch.tensor([2, 0, 1]), VALUES)),
    ("put_", lambda: torch.zeros(3).put_(INDEX, VALUES, accumulate=True)),
    ("bincount with weights", lambda: torch.bincount(INDEX, weights=VALUES)),
    ("histc", lambda: torch.histc(VALUES, bins=3)),
    ("float cumsum", lambda: VALUES.cumsum(0)),
])
def test_each_op_slow_on_cuda_in_deterministic_mode_is_listed(name, operation):
    with SyncAudit() as audit:
        operation()
    assert len(audit.slow) == 1, (name, audit.slow)


def test_their_fast_relatives_are_not_listed():
    with SyncAudit() as audit:
        torch.bincount(INDEX)  # no weights: counts, the same in any order
        INDEX.cumsum(0)  # whole numbers
        torch.zeros(3).scatter_(0, INDEX[:1], 1.0)  # a scalar written, no tensor of values
        VALUES.gather(0, INDEX)
        torch.bmm(torch.ones(1, 2, 3), torch.ones(1, 3, 1))
    assert audit.slow == []
