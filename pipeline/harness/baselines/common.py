"""What the baselines and their stages share: loading windows, co-occurrence groups, batches,
neighbour masks, the epoch loop with its checkpoints.

Co-occurrence: two windows are observed at the same time in the same place when they have the same
`scene_id` and the same `first_frame` (every window starts on a 1 FPS grid of its track, so equal
first frames mean equal frames at every step). Social pooling only ever mixes windows of one group.

Checkpoints (one directory per trained model):
- `last.pt` (`pipeline.checkpoints`, the scheme every training loop shares): everything needed to
  resume: module and optimizer state_dicts, RNG states, the epoch history, the best epoch so far.
  Written at the end of every epoch, and in the middle of one when training is preempted (SIGTERM /
  SIGINT, or the `runtime.max_minutes` budget: see `pipeline.preemption`); then its position holds
  where that epoch stands (see `run_training`), and the next call continues at exactly that batch.
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

import hashlib
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import torch
from torch import nn
from tqdm import tqdm

from pipeline.data.window_table import WindowArrays
from pipeline import checkpoints
from pipeline.harness import epoch_selection
from pipeline.device import CPU, restore_rng_states, rng_states, to_device
from pipeline.io import save_torch
from pipeline.preemption import NEVER, Preemption

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


# Config keys that may change between an interrupted run and its resumption.
RESUMABLE_CHANGES = frozenset({"epochs"})


def run_training(
    *,
    name: str,
    modules: dict[str, nn.Module],
    optimizers: dict[str, torch.optim.Optimizer],
    epoch_batches: Callable[[int], list[np.ndarray]],
    train_batch: Callable[[np.ndarray], np.ndarray],
    loss_names: tuple[str, ...],
    validate: Callable[[], np.ndarray],
    epochs: int,
    config: dict[str, Any],
    meta: dict[str, Any],
    data_fingerprint: str,
    checkpoint_dir: Path,
    generator: torch.Generator,
    device: torch.device = CPU,
    preemption: Preemption = NEVER,
    after_epoch: Callable[[int], None] | None = None,
) -> FitResult:
    """The epoch loop every trained baseline uses: resume, train, validate, checkpoint, keep best.

    epoch_batches(epoch) draws the epoch's batches (window indices; from `generator` only);
    train_batch(index) makes one optimiser step on one of them (drawing randomness from `generator`
    only) and returns its losses, named `loss_names`, whose means over the epoch go to the history;
    validate() returns the validation error of each validation window, (N,) (lower is better),
    without touching `generator`; the history keeps them and their mean (`val_ade`). Every rule of
    `pipeline.harness.epoch_selection` keeps its epoch's weights (`best_path`); the weights of the
    last few epochs stay at hand (in memory and in `last.pt`) until each rule has judged them. On
    return the modules hold the weights `raw` keeps (the lowest mean validation error). The modules live on `device`, `generator`
    too (its state must be restored on the same kind of device).

    Resuming (`pipeline.checkpoints.resume`): a `last.pt` of the same data (`data_fingerprint`:
    windows and seed) and the same config (up to `epochs`, which may only grow) is continued where
    it stopped, and ends exactly where an uninterrupted run would. Any other `last.pt` is stale (the
    settings or the data changed, as when DVC re-runs the stage): training starts afresh and
    overwrites it.

    Preemption: before every optimiser step (and after an epoch's last one) the loop polls
    `preemption.stop_reason()`; when it is set, `last.pt` gets a position (the epoch, the index of
    the next batch, the epoch's batches as drawn and its running loss sums), next to the modules,
    optimizers and RNG states as they are at that point, and `preemption.request(...)` is raised.

    after_epoch(epoch), when given, is called once the epoch is validated and checkpointed, with the
    modules still holding that epoch's weights (in eval mode, under `torch.no_grad`): a diagnostic
    may score them (stage `pecnet_test_selection`). It must leave the modules and `generator` as
    it found them; its time is not counted in `train_seconds`, and an epoch finished before a
    resume is not called again. None (the training stages): nothing else happens.
    """
    checkpoint_dir = Path(checkpoint_dir)
    checkpoint_dir.mkdir(parents=True, exist_ok=True)
    identity = {**{k: v for k, v in config.items() if k not in RESUMABLE_CHANGES},
                "data_fingerprint": data_fingerprint, "selection_rules": dict(epoch_selection.RULES)}
    start, history, seconds, partial = 0, [], 0.0, None
    recent: dict[int, dict[str, dict[str, torch.Tensor]]] = {}  # epoch -> weights, the last few
    kept: dict[str, int] = {}  # rule -> the epoch whose weights its best file holds
    resumed = checkpoints.resume(checkpoint_dir / LAST, identity, config.get("epochs", 0), name)
    if resumed is None:  # nothing stale may survive a fresh start
        for stale in (LAST, *(best_path(checkpoint_dir, rule).name for rule in epoch_selection.RULES)):
            (checkpoint_dir / stale).unlink(missing_ok=True)
    else:
        state = resumed.state
        for key, module in modules.items():
            module.load_state_dict(state["modules"][key])
        for key, opt in optimizers.items():
            opt.load_state_dict(state["optimizers"][key])
        _restore_rng(state, generator, device, checkpoint_dir / LAST)
        start, history, partial = resumed.epoch, list(state["history"]), resumed.position
        seconds = state["train_seconds"]
        recent, kept = dict(state["recent_modules"]), dict(state["kept"])

    def save_last(epochs_done: int, partial_state: dict[str, Any] | None,
                  weights: dict[str, dict[str, torch.Tensor]] | None = None) -> None:
        """`weights`: the modules' state as already copied (at an epoch's end), else copied now."""
        best_epoch = kept.get("raw", -1)  # the lowest mean validation error so far (-1: none yet)
        checkpoints.save(checkpoint_dir / LAST, identity, epochs_done, {
            "config": config, "meta": meta, "best_epoch": best_epoch,
            "best_val": history[best_epoch]["val_ade"] if best_epoch >= 0 else float("inf"),
            "history": history, "train_seconds": seconds,
            "modules": _state_dicts(modules) if weights is None else weights,
            "recent_modules": recent, "kept": kept,
            "optimizers": {k: o.state_dict() for k, o in optimizers.items()},
            "rng": {"generator": generator.get_state(), **rng_states(device)},
            "rng_device": generator.device.type,
        }, partial_state)

    bar = tqdm(range(start, epochs), desc=f"train {name}", initial=start, total=epochs, leave=False)
    for epoch in bar:
        t0 = time.perf_counter()
        if partial is not None:  # the epoch a preempted run stopped in, as it stood then
            batches = [b.numpy() for b in partial["batches"]]
            first, totals = partial["next_batch"], partial["loss_sums"].numpy().copy()
            partial = None
        else:
            batches, first, totals = epoch_batches(epoch), 0, np.zeros(len(loss_names))
        for module in modules.values():
            module.train()
        for i in range(first, len(batches) + 1):
            if preemption.stop_reason() is not None:
                seconds += time.perf_counter() - t0
                save_last(epoch, {"epoch": epoch, "next_batch": i,
                                      "batches": [torch.from_numpy(np.asarray(b, np.int64)) for b in batches],
                                      "loss_sums": torch.from_numpy(totals.copy())})
                raise preemption.request(f"epoch {epoch}, batch {i} of {len(batches)}")
            if i < len(batches):
                totals += train_batch(batches[i])
        losses = dict(zip(loss_names, (totals / len(batches)).tolist(), strict=True))
        for module in modules.values():
            module.eval()
        with torch.no_grad():
            window_errors = np.asarray(validate(), dtype=float)  # (N,)
        val = float(window_errors.mean())
        seconds += time.perf_counter() - t0
        history.append({"epoch": epoch, **losses, "val_ade": val,
                        "val_window_ade": window_errors.tolist()})
        recent[epoch] = _state_dicts(modules)
        curve = np.array([entry["val_ade"] for entry in history])
        for rule in epoch_selection.RULES:
            chosen = epoch_selection.selected_epoch(curve, rule)
            if kept.get(rule) != chosen:  # never older than the weights at hand (see candidates)
                kept[rule] = chosen
                save_torch({"format": BEST_FORMAT, "config": config, "meta": meta, "epoch": chosen,
                            "val_ade": float(curve[chosen]), "selection": rule,
                            "modules": recent[chosen]}, best_path(checkpoint_dir, rule))
        recent = {e: weights for e, weights in recent.items() if e > epoch - epoch_selection.MAX_HALF_WIDTH - 1}
        save_last(epoch + 1, None, recent[epoch])
        if after_epoch is not None:
            with torch.no_grad():
                after_epoch(epoch)
        bar.set_postfix(val_ade=f"{val:.1f}", best=f"{curve[kept['raw']]:.1f}@{kept['raw']}")
    if not history:
        raise ValueError(f"{name}: no epoch trained (epochs = {epochs})")
    best_epoch = kept["raw"]
    best = load_checkpoint(checkpoint_dir / BEST, map_location=device)
    for key, module in modules.items():
        module.load_state_dict(best["modules"][key])
        module.eval()
    return FitResult(best_epoch=best_epoch, best_val_ade=history[best_epoch]["val_ade"],
                     epochs=len(history), train_seconds=seconds, history=history, selected=dict(kept))


def _state_dicts(modules: dict[str, nn.Module]) -> dict[str, dict[str, torch.Tensor]]:
    return {k: checkpoints.cpu_state_dict(m) for k, m in modules.items()}


def _restore_rng(state: dict[str, Any], generator: torch.Generator, device: torch.device, path: Path) -> None:
    """Put back the RNG states of a `last.pt`'s state. A generator state only fits a generator of the
    same device type: resumed on another kind of device, the weights, optimizers and position
    carry over and the training generator is re-seeded from the saved state (deterministic, but
    not the numbers an uninterrupted run would have drawn; nor are another device's kernels)."""
    rng = state["rng"]
    saved_on = state["rng_device"]
    if saved_on == generator.device.type:
        generator.set_state(rng["generator"])
    else:
        seed = int.from_bytes(hashlib.sha256(rng["generator"].numpy().tobytes()).digest()[:8], "little")
        generator.manual_seed(seed)
        tqdm.write(f"{path}: written on {saved_on}, resuming on {generator.device.type}: the training "
                   "generator restarts from a seed derived from its saved state")
    restore_rng_states(rng, device)


def fit_result_from(checkpoint_dir: Path) -> FitResult:
    """The FitResult recorded in a checkpoint directory's `last.pt`."""
    state = checkpoints.read(Path(checkpoint_dir) / LAST).state
    return FitResult(best_epoch=state["best_epoch"], best_val_ade=state["best_val"],
                     epochs=len(state["history"]), train_seconds=state["train_seconds"],
                     history=list(state["history"]), selected=dict(state.get("kept", {})))
