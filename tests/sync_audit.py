"""Counting, on the CPU, the operations that would make the host wait for a GPU.

With its tensors on CUDA, a training step runs ahead of the GPU until something needs a value on
the host: a scalar read (`.item()`, `float()`, `bool()`, what `aten::_local_scalar_dense` does), a
copy to the host (`.cpu()`, `.tolist()`, `.numpy()`), an op whose output size depends on values
(`nonzero`, a boolean-mask read or write), or an index built from host data (a list or numpy
array: torch makes a tensor of it on the host and copies it to the GPU, blocking). None of these
needs a GPU to be seen: `SyncAudit` watches every torch call and every dispatched operator of a
CPU run (under `torch.inference_mode` too) and records each such one in `events`, and every
operator in `ops` (to compare the work of two steps). Operator-level events (scalar reads,
`nonzero`, boolean masks) are seen wherever they happen; `.cpu()` / `.tolist()` / `.numpy()` and
list or numpy indices where our code or torch's non-Python code calls them, not inside a torch
function written in Python (a torch function mode is off while its function runs). A `.to(device)` is not judged (on the CPU it
cannot tell a copy to the host from one to the device).

`slow` lists every dispatched operator whose CUDA kernel, under scoring's
`torch.use_deterministic_algorithms(True)`, takes a slow deterministic path (a sort before an
accumulation) or has no deterministic version at all (`slow_when_deterministic`).

Some tensors stay on the host in a CUDA run too (Adam's step counts, unless `capturable`):
reading them, or what is computed from them alone, costs the GPU nothing. Pass them as
`host_tensors` (`host_state`).
"""

from __future__ import annotations

from collections import Counter

import numpy as np
import torch
from torch.overrides import TorchFunctionMode
from torch.utils._python_dispatch import TorchDispatchMode
from torch.utils._pytree import tree_leaves

# Scalar reads: under `torch.inference_mode` (scoring) `.item()`, `float()` and `bool()` reach the
# dispatcher as `item` / `is_nonzero`, whose `_local_scalar_dense` is not dispatched again.
SCALAR_READS = {torch.ops.aten._local_scalar_dense.default, torch.ops.aten.item.default,
                torch.ops.aten.is_nonzero.default}
VALUE_SIZED = {torch.ops.aten.nonzero.default, torch.ops.aten.masked_select.default}
INDEXING = {torch.ops.aten.index.Tensor, torch.ops.aten.index_put_.default,
            torch.ops.aten.index_put.default, torch.ops.aten._index_put_impl_.default}
TO_HOST = {torch.Tensor.cpu: "cpu", torch.Tensor.numpy: "numpy", torch.Tensor.tolist: "tolist"}

# torch.use_deterministic_algorithms' list (PyTorch 2.x): on CUDA in deterministic mode these
# accumulate or write through a sort (`index_put` with or without accumulate, which `scatter_add_`,
# `scatter` of a tensor, `index_add` and `index_copy` end in) or raise / warn for lack of a
# deterministic kernel (`put_`, `histc`, `index_reduce`, `median` with indices, `kthvalue`).
ops = torch.ops.aten
SLOW_WHEN_DETERMINISTIC = {
    ops.index_put.default, ops.index_put_.default, ops._index_put_impl_.default,
    ops.scatter_add.default, ops.scatter_add_.default, ops.scatter.src, ops.scatter_.src,
    ops.scatter.reduce, ops.scatter_.reduce, ops.scatter_reduce.two, ops.scatter_reduce_.two,
    ops.index_add.default, ops.index_add_.default, ops.index_copy.default, ops.index_copy_.default,
    ops.index_reduce.default, ops.index_reduce_.default, ops.put.default, ops.put_.default,
    ops.histc.default, ops.median.dim, ops.nanmedian.dim, ops.kthvalue.default,
}
del ops


def slow_when_deterministic(func, args, kwargs) -> bool:
    """Whether `func(*args, **kwargs)` would take a slow deterministic path, or have none, on CUDA
    under `torch.use_deterministic_algorithms(True)`: the ops of `SLOW_WHEN_DETERMINISTIC`, a
    `bincount` with weights and a floating-point `cumsum`."""
    if func in SLOW_WHEN_DETERMINISTIC:
        return True
    if func is torch.ops.aten.bincount.default:
        return (args[1] if len(args) > 1 else kwargs.get("weights")) is not None
    if func in (torch.ops.aten.cumsum.default, torch.ops.aten.cumsum_.default):
        dtype = kwargs.get("dtype") or args[0].dtype
        return dtype.is_floating_point or dtype.is_complex
    return False


def host_state(optimizer: torch.optim.Optimizer) -> list[torch.Tensor]:
    """The optimiser's state tensors that torch keeps on the host on CUDA too (the step counts of
    Adam and its kin when neither `capturable` nor `fused`)."""
    kept = []
    for group in optimizer.param_groups:
        if group.get("capturable") or group.get("fused"):
            continue
        for p in group["params"]:
            step = optimizer.state.get(p, {}).get("step")
            if isinstance(step, torch.Tensor):
                kept.append(step)
    return kept


def _host_data_index(index) -> bool:
    """Whether a `tensor[index]` index holds a list or numpy array (made a host tensor, copied)."""
    parts = index if isinstance(index, tuple) else (index,)
    return any(isinstance(part, (list, np.ndarray)) for part in parts)


class _Functions(TorchFunctionMode):
    def __init__(self, audit: SyncAudit):
        super().__init__()
        self.audit = audit

    def __torch_function__(self, func, types, args=(), kwargs=None):
        kwargs = kwargs or {}
        if func in TO_HOST and not self.audit.on_host(args[0]):
            self.audit.events.append((TO_HOST[func], tuple(args[0].shape)))
        elif func in (torch.Tensor.__getitem__, torch.Tensor.__setitem__) and _host_data_index(args[1]):
            self.audit.events.append(("index from host data", type(args[1]).__name__))
        return func(*args, **kwargs)


class _Operators(TorchDispatchMode):
    def __init__(self, audit: SyncAudit):
        super().__init__()
        self.audit = audit

    def __torch_dispatch__(self, func, types, args=(), kwargs=None):
        kwargs = kwargs or {}
        audit = self.audit
        inputs = [t for t in tree_leaves((args, kwargs)) if isinstance(t, torch.Tensor)]
        from_host = bool(inputs) and all(audit.on_host(t) for t in inputs)
        audit.ops[str(func)] += 1
        if slow_when_deterministic(func, args, kwargs):
            audit.slow.append(str(func))
        if func in SCALAR_READS and not from_host:
            audit.events.append(("scalar read", str(args[0].dtype)))
        elif func in VALUE_SIZED:
            audit.events.append((str(func), tuple(args[0].shape)))
        elif func in INDEXING and any(t is not None and t.dtype == torch.bool for t in args[1]):
            audit.events.append(("boolean mask", str(func)))
        out = func(*args, **kwargs)
        if from_host:  # computed from host tensors alone: on the host too
            audit.host.update((id(t), t) for t in tree_leaves(out) if isinstance(t, torch.Tensor))
        return out


class SyncAudit:
    """`with SyncAudit() as audit: ...`, then `audit.events`: (what, detail) for every operation
    that would wait for a GPU; `audit.ops`: how often each operator was dispatched (views
    included); `audit.slow`: the operators dispatched that are slow on CUDA in deterministic mode."""

    def __init__(self, host_tensors=()):
        self.host = {id(t): t for t in host_tensors}  # held, so that no other tensor gets the id
        self.events: list[tuple[str, object]] = []
        self.ops: Counter[str] = Counter()
        self.slow: list[str] = []
        self._modes = (_Functions(self), _Operators(self))

    def on_host(self, tensor: torch.Tensor) -> bool:
        return id(tensor) in self.host

    def __enter__(self) -> SyncAudit:
        for mode in self._modes:
            mode.__enter__()
        return self

    def __exit__(self, *exc) -> None:
        for mode in reversed(self._modes):
            mode.__exit__(*exc)
