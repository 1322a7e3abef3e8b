"""The epoch loop every trained baseline (S-GAN, PECNet) runs: resume, train, validate, checkpoint,
keep the epoch of every selection rule (`run_training`, called by each baseline's `fit`).

What the loop writes to a checkpoint folder, and what reads it back (`best_path`, `load_checkpoint`,
`fit_result_from`): `common`. `last.pt` follows the scheme every training loop shares
(`pipeline.checkpoints`); in the middle of an epoch (preempted: `pipeline.preemption`) its position
holds where that epoch stands, and the next call continues at exactly that batch. It lives beside
the models, not in `pipeline/checkpoints.py`, because only the baselines run it: Y-net's loop is
`pipeline.runners.ynet_training`.
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

from pipeline import checkpoints
from pipeline.device import CPU, restore_rng_states, rng_states
from pipeline.harness import epoch_selection
from pipeline.io import save_torch
from pipeline.preemption import NEVER, Preemption
from pipeline.runners.baselines.common import BEST, BEST_FORMAT, LAST, FitResult, best_path, load_checkpoint

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
    return the modules hold the weights `raw` keeps (the lowest mean validation error). The
    modules live on `device`, `generator` too (its state must be restored on the same kind of
    device).

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
    run = _Run(Path(checkpoint_dir), modules, optimizers, config, meta, generator, device,
               identity={**{k: v for k, v in config.items() if k not in RESUMABLE_CHANGES},
                         "data_fingerprint": data_fingerprint,
                         "selection_rules": dict(epoch_selection.RULES)})
    run.checkpoint_dir.mkdir(parents=True, exist_ok=True)
    _resume_or_start(run, config.get("epochs", 0), name)
    bar = tqdm(range(run.start, epochs), desc=f"train {name}", initial=run.start, total=epochs, leave=False)
    for epoch in bar:
        t0 = time.perf_counter()
        batches, first, totals = _batches_of(run, epoch, epoch_batches, len(loss_names))
        _train_epoch(run, epoch, batches, first, totals, train_batch, preemption, t0)
        losses = dict(zip(loss_names, (totals / len(batches)).tolist(), strict=True))
        val = _validate_and_keep(run, epoch, losses, validate, t0)
        if after_epoch is not None:
            with torch.no_grad():
                after_epoch(epoch)
        best = run.kept["raw"]
        bar.set_postfix(val_ade=f"{val:.1f}", best=f"{run.history[best]['val_ade']:.1f}@{best}")
    if not run.history:
        raise ValueError(f"{name}: no epoch trained (epochs = {epochs})")
    return _kept_by_raw(run)


@dataclass
class _Run:
    """One training run's state between steps: what `last.pt` holds besides the modules, optimizers
    and RNG states, with what the loop needs to write it."""

    checkpoint_dir: Path
    modules: dict[str, nn.Module]
    optimizers: dict[str, torch.optim.Optimizer]
    config: dict[str, Any]
    meta: dict[str, Any]
    generator: torch.Generator
    device: torch.device
    identity: dict[str, Any]
    start: int = 0  # the first epoch this call trains
    history: list[dict[str, Any]] = field(default_factory=list)
    seconds: float = 0.0
    partial: dict[str, Any] | None = None  # the position of a preempted epoch
    # epoch -> weights, the last few (until every rule has judged them)
    recent: dict[int, dict[str, dict[str, torch.Tensor]]] = field(default_factory=dict)
    kept: dict[str, int] = field(default_factory=dict)  # rule -> the epoch whose weights its best file holds

    def save_last(self, epochs_done: int, partial_state: dict[str, Any] | None,
                  weights: dict[str, dict[str, torch.Tensor]] | None = None) -> None:
        """`weights`: the modules' state as already copied (at an epoch's end), else copied now."""
        best_epoch = self.kept.get("raw", -1)  # the lowest mean validation error so far (-1: none yet)
        checkpoints.save(self.checkpoint_dir / LAST, self.identity, epochs_done, {
            "config": self.config, "meta": self.meta, "best_epoch": best_epoch,
            "best_val": self.history[best_epoch]["val_ade"] if best_epoch >= 0 else float("inf"),
            "history": self.history, "train_seconds": self.seconds,
            "modules": _state_dicts(self.modules) if weights is None else weights,
            "recent_modules": self.recent, "kept": self.kept,
            "optimizers": {k: o.state_dict() for k, o in self.optimizers.items()},
            "rng": {"generator": self.generator.get_state(), **rng_states(self.device)},
            "rng_device": self.generator.device.type,
        }, partial_state)


def _resume_or_start(run: _Run, target_epochs: int, name: str) -> None:
    """Continue a `last.pt` of this run (modules, optimizers, RNGs, history, position), or start
    afresh, removing whatever a stale run left."""
    resumed = checkpoints.resume(run.checkpoint_dir / LAST, run.identity, target_epochs, name)
    if resumed is None:  # nothing stale may survive a fresh start
        for stale in (LAST, *(best_path(run.checkpoint_dir, rule).name for rule in epoch_selection.RULES)):
            (run.checkpoint_dir / stale).unlink(missing_ok=True)
        return
    state = resumed.state
    for key, module in run.modules.items():
        module.load_state_dict(state["modules"][key])
    for key, opt in run.optimizers.items():
        opt.load_state_dict(state["optimizers"][key])
    _restore_rng(state, run.generator, run.device, run.checkpoint_dir / LAST)
    run.start, run.history, run.partial = resumed.epoch, list(state["history"]), resumed.position
    run.seconds = state["train_seconds"]
    run.recent, run.kept = dict(state["recent_modules"]), dict(state["kept"])


def _batches_of(run: _Run, epoch: int, epoch_batches: Callable[[int], list[np.ndarray]],
                n_losses: int) -> tuple[list[np.ndarray], int, np.ndarray]:
    """The epoch's batches, the first to train and the running loss sums: as a preempted run left
    them in its position, else freshly drawn."""
    if run.partial is None:
        return epoch_batches(epoch), 0, np.zeros(n_losses)
    partial, run.partial = run.partial, None
    return ([b.numpy() for b in partial["batches"]], partial["next_batch"],
            partial["loss_sums"].numpy().copy())


def _train_epoch(run: _Run, epoch: int, batches: list[np.ndarray], first: int, totals: np.ndarray,
                 train_batch: Callable[[np.ndarray], np.ndarray], preemption: Preemption,
                 t0: float) -> None:
    """One optimiser step per batch from `first` on, adding its losses to `totals`; asked to stop,
    write the position to `last.pt` and raise the request."""
    for module in run.modules.values():
        module.train()
    for i in range(first, len(batches) + 1):
        if preemption.stop_reason() is not None:
            run.seconds += time.perf_counter() - t0
            run.save_last(epoch, {"epoch": epoch, "next_batch": i,
                                  "batches": [torch.from_numpy(np.asarray(b, np.int64)) for b in batches],
                                  "loss_sums": torch.from_numpy(totals.copy())})
            raise preemption.request(f"epoch {epoch}, batch {i} of {len(batches)}")
        if i < len(batches):
            totals += train_batch(batches[i])


def _validate_and_keep(run: _Run, epoch: int, losses: dict[str, float],
                       validate: Callable[[], np.ndarray], t0: float) -> float:
    """Validate the epoch, record it, write the best file of every rule whose choice changed and
    `last.pt`; returns the mean validation error."""
    for module in run.modules.values():
        module.eval()
    with torch.no_grad():
        window_errors = np.asarray(validate(), dtype=float)  # (N,)
    val = float(window_errors.mean())
    run.seconds += time.perf_counter() - t0
    run.history.append({"epoch": epoch, **losses, "val_ade": val,
                        "val_window_ade": window_errors.tolist()})
    run.recent[epoch] = _state_dicts(run.modules)
    curve = np.array([entry["val_ade"] for entry in run.history])
    for rule in epoch_selection.RULES:
        chosen = epoch_selection.selected_epoch(curve, rule)
        if run.kept.get(rule) != chosen:  # never older than the weights at hand (see candidates)
            run.kept[rule] = chosen
            save_torch({"format": BEST_FORMAT, "config": run.config, "meta": run.meta, "epoch": chosen,
                        "val_ade": float(curve[chosen]), "selection": rule,
                        "modules": run.recent[chosen]}, best_path(run.checkpoint_dir, rule))
    run.recent = {e: weights for e, weights in run.recent.items()
                  if e > epoch - epoch_selection.MAX_HALF_WIDTH - 1}
    run.save_last(epoch + 1, None, run.recent[epoch])
    return val


def _kept_by_raw(run: _Run) -> FitResult:
    """Load the weights `raw` keeps into the modules (eval mode) and report the run."""
    best_epoch = run.kept["raw"]
    best = load_checkpoint(run.checkpoint_dir / BEST, map_location=run.device)
    for key, module in run.modules.items():
        module.load_state_dict(best["modules"][key])
        module.eval()
    return FitResult(best_epoch=best_epoch, best_val_ade=run.history[best_epoch]["val_ade"],
                     epochs=len(run.history), train_seconds=run.seconds, history=run.history,
                     selected=dict(run.kept))


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
