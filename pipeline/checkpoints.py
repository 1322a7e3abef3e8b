"""The one resumable-checkpoint scheme every training loop uses (U-Net, Y-net, the baselines).

A training run keeps `last.pt` in its checkpoint folder: everything needed to continue exactly
where it stopped, written at the end of every epoch and, when the run is preempted (SIGTERM /
SIGINT or `runtime.max_minutes`, see `pipeline.preemption`), in the middle of one. Its envelope is
the same for every loop:

    {"format": FORMAT,
     "identity": {...},   # what the run depends on besides its epoch budget: settings, data, seed
     "epoch": int,        # epochs completed
     "position": dict | None,  # mid-epoch: where epoch `epoch` (0-based) stopped, the loop's own
     "state": {...}}      # the loop's own: state_dicts, RNG states, history

`resume` decides, the same way for every loop, whether a `last.pt` can be continued: the same
format, the same identity (compared key by key, so the notice names what changed) and no more
epochs begun than the run now asks for (the epoch budget may grow: a run extended from 30 to 60
epochs continues). Anything else is stale, as when DVC re-runs a stage after its settings or data
changed: `resume` says why and the loop starts afresh, overwriting it.

Files are written atomically (`pipeline.io.save_torch`) and hold only tensors and plain values,
loaded with `weights_only=True` onto the CPU (RNG states must be CPU tensors; `load_state_dict`
moves the rest onto the model's device), so a checkpoint written on a GPU resumes anywhere.
The kept weights (`best.pt`, a model export) are each loop's own: they are what evaluation loads.

`run_digest` is the one hash of what a run trains on (its settings or seed, its windows, its scene
maps) that the loops put into their identities, and `seed_everything` the one seeding of Python's,
numpy's and torch's global RNGs they start with.
"""

from __future__ import annotations

import hashlib
import random
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import torch

from pipeline.device import CPU
from pipeline.device import generator as seeded_generator
from pipeline.io import save_torch

FORMAT = "resumable/1"
LAST = "last.pt"
BEST = "best.pt"


@dataclass(frozen=True)
class Resumed:
    """A checkpoint a run continues from."""

    epoch: int  # epochs completed
    position: dict[str, Any] | None  # the loop's mid-epoch position in epoch `epoch`, or None
    state: dict[str, Any]  # the loop's state


def stale_reason(saved: Any, identity: dict[str, Any], epochs: int) -> str | None:
    """Why the checkpoint `saved` cannot be continued by a run of `identity` and `epochs` epochs
    (None: it can)."""
    if not isinstance(saved, dict) or saved.get("format") != FORMAT:
        found = saved.get("format") if isinstance(saved, dict) else type(saved).__name__
        return f"has checkpoint format {found!r}, this code reads {FORMAT!r}"
    saved_identity = saved["identity"]
    changed = sorted(key for key in set(saved_identity) | set(identity)
                     if saved_identity.get(key) != identity.get(key))
    if changed:
        return f"was trained with other {', '.join(changed)}"
    begun = saved["epoch"] + (saved["position"] is not None)
    if begun > epochs:
        return f"has begun {begun} epochs, more than the {epochs} asked for"
    return None


def load(path: Path) -> dict[str, Any]:
    """A `last.pt` as saved (tensors on the CPU), whatever its format."""
    return torch.load(Path(path), map_location="cpu", weights_only=True)


def read(path: Path) -> Resumed:
    """The checkpoint at `path`, whatever its identity (what a finished run recorded); an error
    naming the file if it is not of this scheme."""
    saved = load(path)
    if not isinstance(saved, dict) or saved.get("format") != FORMAT:
        raise ValueError(f"{path}: not a checkpoint of format {FORMAT!r}")
    return Resumed(epoch=saved["epoch"], position=saved["position"], state=saved["state"])


def resume(path: Path, identity: dict[str, Any], epochs: int, who: str) -> Resumed | None:
    """The checkpoint at `path` if a run of `identity` and `epochs` epochs can continue from it;
    otherwise None, after printing why (nothing when there is no file)."""
    path = Path(path)
    if not path.exists():
        return None
    saved = load(path)
    why = stale_reason(saved, identity, epochs)
    if why is not None:
        print(f"{who}: {path} {why}; starting afresh", flush=True)
        return None
    return Resumed(epoch=saved["epoch"], position=saved["position"], state=saved["state"])


def save(path: Path, identity: dict[str, Any], epoch: int, state: dict[str, Any],
         position: dict[str, Any] | None = None) -> None:
    """Write `last.pt` atomically: `epoch` epochs completed, `position` inside the next one."""
    save_torch({"format": FORMAT, "identity": identity, "epoch": int(epoch), "position": position,
                "state": state}, Path(path), in_memory=True)


def cpu_state_dict(module: torch.nn.Module) -> dict[str, torch.Tensor]:
    """A copy of the module's state_dict as CPU tensors (a GPU run's checkpoint loads anywhere)."""
    return {name: tensor.detach().to("cpu", copy=True) for name, tensor in module.state_dict().items()}


def run_digest(head: str, *windows: Any, maps: Mapping[str, np.ndarray] | None = None) -> str:
    """SHA-256 of what a training run trains on: `head` (its settings or seed, as text), then each
    window set of `windows` (`pipeline.data.window_table.WindowArrays`: ids, first frames, observed
    and future positions, scenes) and each scene map of `maps` by name, in name order."""
    digest = hashlib.sha256(head.encode())
    for arrays in windows:
        for values in (arrays.window_id, arrays.first_frame, arrays.past, arrays.future):
            digest.update(np.ascontiguousarray(values).tobytes())
        digest.update("\x00".join(map(str, arrays.scene_id)).encode())
    for name in sorted(maps or {}):
        digest.update(name.encode())
        digest.update(np.ascontiguousarray(maps[name]).tobytes())
    return digest.hexdigest()


def seed_everything(seed: int, device: torch.device = CPU) -> torch.Generator:
    """Seed Python's, numpy's and torch's global RNGs (CPU and CUDA) with `seed`; return a
    torch.Generator on `device` seeded with `seed`, for a loop that draws its randomness from one
    (the baselines: shuffling, noise, latents; on the CPU the generator they have always used)."""
    random.seed(seed)
    np.random.seed(seed)
    torch.manual_seed(seed)
    return seeded_generator(device, seed)
