"""What the baselines and their stages share: co-occurrence groups, batches, neighbour masks, and
the checkpoints their training loop (`training.run_training`) writes.

Co-occurrence: two windows are observed at the same time in the same place when they have the same
`scene_id` and the same `first_frame` (every window starts on a 1 FPS grid of its track, so equal
first frames mean equal frames at every step). Social pooling only ever mixes windows of one group.

Checkpoints (one directory per trained model):
- `last.pt` (`pipeline.checkpoints`, the scheme every training loop shares): everything needed to
  resume: module and optimizer state_dicts, RNG states, the epoch history, the best epoch so far.
  Written at the end of every epoch, and in the middle of one when training is preempted (SIGTERM /
  SIGINT, or the `runtime.max_minutes` budget: see `pipeline.preemption`); then its position holds
  where that epoch stands, and the next call continues at exactly that batch.
- `best.pt`: the module state_dicts of the epoch with the lowest validation error, the config and
  what the model needs to predict (n_past, n_future). What evaluation loads by default.
- `best_<rule>.pt`, one per smoothed selection rule of `pipeline.harness.epoch_selection`
  (`mean3`, ...): the same for the epoch that rule keeps; `best_path` names them, and
  `evaluate_baseline.epoch_selection` says which one evaluation loads.
All are written to a temporary file and renamed, so an interruption never leaves a torn file, and
both hold only tensors (module weights always as CPU tensors) and plain Python values (loaded with
`weights_only=True` and a `map_location`), so a checkpoint written on a GPU loads on a CPU.

Devices: every model takes a `device`; modules live there, batches are built on the CPU and moved
with `pipeline.device.to_device`, and random draws are made on the device of the generator they
come from, then moved (so a CUDA model also accepts a CPU generator, and a CPU run draws exactly the
numbers it always drew). No autocast: these are small MLPs and LSTMs (widths <= 1024, batches <= 512
windows, LSTM steps one at a time), whose GPU time goes to kernel launches and Python rather than
matmul throughput, so bfloat16 would add cast kernels and cost the KL and variety losses precision
for little if any speed-up (an expectation, not measured: no GPU was at hand). TF32 matmuls come
from `pipeline.device.select_device`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import torch
from torch import nn

from pipeline.data.window_table import WindowArrays
from pipeline import checkpoints
from pipeline.harness import epoch_selection
from pipeline.device import CPU, to_device

BEST_FORMAT = 2  # of `best.pt`; format 1 differs only in what `last.pt` held then
READABLE_FORMATS = (1, 2)
LAST, BEST = checkpoints.LAST, checkpoints.BEST


# ---------------------------------------------------------------------------------------------
# Groups, batches and neighbours


def co_occurrence_groups(arrays: WindowArrays) -> np.ndarray:
    """(N,) int64 group index; windows with equal (scene_id, first_frame) share one."""
    keys = np.char.add(np.char.add(arrays.scene_id.astype(str), "\x00"),
                       arrays.first_frame.astype(str))
    _, groups = np.unique(keys, return_inverse=True)
    return groups.astype(np.int64)


def group_batches(groups: np.ndarray, batch_size: int,
                  generator: torch.Generator | None = None) -> list[np.ndarray]:
    """Window indices in batches of whole groups, about `batch_size` windows each.

    Groups are visited in a random order when `generator` is given (training), in index order
    otherwise. A group larger than `batch_size` is a batch of its own (never split: its windows
    pool with each other).
    """
    order = np.unique(groups)
    if generator is not None:  # drawn on the generator's device (one small copy back per epoch)
        order = order[torch.randperm(len(order), generator=generator, device=generator.device).cpu().numpy()]
    members = _group_members(groups)
    batches, current, size = [], [], 0
    for g in order:
        idx = members[g]
        if size and size + len(idx) > batch_size:
            batches.append(np.concatenate(current))
            current, size = [], 0
        current.append(idx)
        size += len(idx)
    if current:
        batches.append(np.concatenate(current))
    return batches


def _group_members(groups: np.ndarray) -> dict[int, np.ndarray]:
    order = np.argsort(groups, kind="stable")
    values, starts = np.unique(groups[order], return_index=True)
    return dict(zip(values.tolist(), np.split(order, starts[1:]), strict=True))


def neighbour_mask(groups: torch.Tensor, positions: torch.Tensor,
                   radius: float | None = None) -> torch.Tensor:
    """(B, B) bool: i and j co-occur and, when `radius` is given, come within `radius` of each other.

    groups: (B,) int; positions: (B, T, 2) positions at the same T time steps for every window
    (the observed steps: known at test time). The distance is the minimum over those steps. The
    diagonal is always True (an agent pools with itself).
    """
    same = groups[:, None] == groups[None, :]  # (B, B)
    if radius is not None:
        dist = torch.linalg.vector_norm(positions[:, None] - positions[None, :], dim=-1)  # (B, B, T)
        same = same & (dist.amin(dim=-1) < radius)
    return same | torch.eye(len(groups), dtype=torch.bool, device=groups.device)


def check_windows(arrays: WindowArrays, n_past: int, n_future: int | None, what: str) -> None:
    """Fail unless `arrays` has windows of n_past observed (+ n_future) steps."""
    if arrays.past.shape[1] != n_past or (n_future is not None and arrays.future.shape[1] != n_future):
        raise ValueError(f"{what}: the model takes {n_past} observed + {n_future} future steps, "
                         f"the windows have {arrays.past.shape[1]} + {arrays.future.shape[1]}")


def mlp(sizes: list[int], activation: type[nn.Module] = nn.ReLU, last_activation: bool = False) -> nn.Sequential:
    """Linear layers of the given widths (input first, output last) with activations between."""
    layers: list[nn.Module] = []
    for i, (a, b) in enumerate(zip(sizes[:-1], sizes[1:])):
        layers.append(nn.Linear(a, b))
        if i < len(sizes) - 2 or last_activation:
            layers.append(activation())
    return nn.Sequential(*layers)


# ---------------------------------------------------------------------------------------------
# Checkpoints


def as_input(values: np.ndarray, device: torch.device, dtype: torch.dtype | None = None) -> torch.Tensor:
    """A numpy array as a tensor on `device`: made on the CPU, then moved with `to_device` (pinned,
    non-blocking to CUDA; the very same tensor on the CPU)."""
    return to_device(torch.as_tensor(values, dtype=dtype, device=CPU), device)


def best_path(checkpoint_dir: Path, rule: str = "raw") -> Path:
    """The kept weights of selection rule `rule` in a checkpoint folder (`raw`: `best.pt`)."""
    epoch_selection.half_width(rule)  # a clear error for an unknown rule
    return Path(checkpoint_dir) / (BEST if rule == "raw" else f"best_{rule}.pt")


def load_checkpoint(path: Path, map_location: torch.device | str = "cpu") -> dict[str, Any]:
    """A `best.pt` written by `run_training` (tensors and plain values only), its tensors on
    `map_location`."""
    state = torch.load(Path(path), map_location=map_location, weights_only=True)
    if state.get("format") not in READABLE_FORMATS:
        raise ValueError(f"{path}: checkpoint format {state.get('format')}, expected one of {READABLE_FORMATS}")
    return state


@dataclass
class FitResult:
    """What a training run reports."""

    best_epoch: int  # 0-based epoch whose weights were kept
    best_val_ade: float  # its validation error (min-over-K ADE, pixels)
    epochs: int  # epochs trained in total (over all resumed runs)
    train_seconds: float  # wall time of training, summed over resumed runs
    history: list[dict[str, Any]] = field(default_factory=list)  # one entry per epoch
    selected: dict[str, int] = field(default_factory=dict)  # rule -> epoch it keeps (best_path)

    def window_curves(self) -> np.ndarray:
        """(E, N) validation ADE of each validation window after each epoch."""
        return np.array([epoch["val_window_ade"] for epoch in self.history], dtype=float)


def fit_result_from(checkpoint_dir: Path) -> FitResult:
    """The FitResult recorded in a checkpoint directory's `last.pt`."""
    state = checkpoints.read(Path(checkpoint_dir) / LAST).state
    return FitResult(best_epoch=state["best_epoch"], best_val_ade=state["best_val"],
                     epochs=len(state["history"]), train_seconds=state["train_seconds"],
                     history=list(state["history"]), selected=dict(state.get("kept", {})))
