"""Rewrite `last.pt` files of the three older checkpoint layouts in the `pipeline.checkpoints` scheme.

Before that scheme, the Y-net, U-Net and baseline loops each wrote `last.pt` their own way; the
code now reads only the shared scheme and starts afresh from anything else. Runs trained before
(hours of CPU for Y-net) keep their progress by upgrading their files in place, once:

    python tools/upgrade_checkpoints.py checkpoints data/segmentation/checkpoints

Every `last.pt` under the given folders is read, recognised by its keys, and rewritten atomically
with the same tensors and values; files already in the new scheme are left alone; anything else is
an error naming the file. `--check` only lists what would change.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

if __package__ in (None, ""):
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from pipeline import checkpoints  # noqa: E402
from pipeline.harness.baselines.common import RESUMABLE_CHANGES  # noqa: E402


def upgraded(saved: dict[str, Any], path: Path) -> dict[str, Any] | None:
    """The file's content in the shared scheme's envelope, or None if it already is in it."""
    if saved.get("format") == checkpoints.FORMAT:
        return None
    if "run_id" in saved and "state" in saved:  # Y-net (pipeline.runners.ynet_training)
        progress = saved["state"]
        losses = list(saved.get("partial_losses", []))  # absent before mid-epoch checkpoints
        return {"identity": {"run": saved["run_id"]}, "epoch": progress["epoch"],
                # no step taken in the epoch is the same as its start: the plan RNG state is the
                # one saved at the end of the previous epoch
                "position": {"losses": losses} if losses else None,
                "state": {"model": saved["model"], "optimizer": saved["optimizer"],
                          "rng": saved["rng"], "progress": {key: progress[key] for key in
                                                            ("history", "best", "seconds")}}}
    if saved.get("format") in (1, 2) and "fingerprint" in saved:  # U-Net (runners.segmentation)
        return {"identity": {"run": saved["fingerprint"]}, "epoch": len(saved["log"]),
                "position": saved.get("position"),
                "state": {"model": saved["model"], "optimiser": saved["optimiser"],
                          "log": saved["log"], "rng": saved.get("rng")}}
    if saved.get("format") in (1, 2) and "data_fingerprint" in saved:  # baselines (harness)
        config = saved["config"]
        identity = {**{k: v for k, v in config.items() if k not in RESUMABLE_CHANGES},
                    "data_fingerprint": saved["data_fingerprint"]}
        return {"identity": identity, "epoch": saved["epoch"] + 1, "position": saved.get("partial"),
                "state": {"config": config, "meta": saved["meta"], "best_epoch": saved["best_epoch"],
                          "best_val": saved["best_val"], "history": saved["history"],
                          "train_seconds": saved["train_seconds"], "modules": saved["modules"],
                          "optimizers": saved["optimizers"], "rng": saved["rng"],
                          "rng_device": saved.get("rng_device", "cpu")}}
    raise ValueError(f"{path}: not a checkpoint of any layout this tool knows "
                     f"(keys: {sorted(saved)[:12]})")


def upgrade(path: Path, check: bool = False) -> bool:
    """Rewrite one `last.pt`; True if it was (or, with `check`, would be) rewritten."""
    new = upgraded(checkpoints.load(path), path)
    if new is None:
        return False
    if not check:
        checkpoints.save(path, new["identity"], new["epoch"], new["state"], new["position"])
    return True


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("folders", nargs="+", type=Path)
    parser.add_argument("--check", action="store_true", help="list, do not rewrite")
    args = parser.parse_args(argv)
    for folder in args.folders:
        for path in sorted(folder.rglob(checkpoints.LAST)):
            if upgrade(path, args.check):
                print(f"{'would upgrade' if args.check else 'upgraded'} {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
