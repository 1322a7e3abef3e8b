"""Old vs new outputs of an identity check (`model_list_identity.sh`, `benchmarks_identity.sh`):
every file byte-identical, or identical but for the output folder's own name (a predictions file
records its checkpoint folder: its columns and its metadata, with one folder's name replaced by
the other's, are compared), or, where a file records how long it took (JSON, CSV, torch
checkpoints), identical but for those timings.

    python -m docs.experiments.identity_compare OLD_DIR NEW_DIR
"""
import json
import sys
from pathlib import Path

import pandas as pd
import pyarrow.parquet as pq
import torch

TIMINGS = {"eval_seconds", "eval_seconds_per_round", "train_seconds", "wall_seconds",
           "seconds_per_epoch", "score_seconds", "fit_seconds", "seconds", "epoch_seconds"}


def strip(value):
    if isinstance(value, dict):
        return {k: strip(v) for k, v in value.items() if k not in TIMINGS}
    if isinstance(value, (list, tuple)):
        return [strip(v) for v in value]
    return value


def same_content(a, b) -> bool:
    if isinstance(a, torch.Tensor) or isinstance(b, torch.Tensor):
        return (isinstance(a, torch.Tensor) and isinstance(b, torch.Tensor)
                and a.dtype == b.dtype and a.shape == b.shape and torch.equal(a, b))
    if isinstance(a, dict) and isinstance(b, dict):
        keys = (set(a) | set(b)) - TIMINGS
        return all(k in a and k in b and same_content(a[k], b[k]) for k in keys)
    if isinstance(a, (list, tuple)) and isinstance(b, (list, tuple)):
        return len(a) == len(b) and all(same_content(x, y) for x, y in zip(a, b))
    return a == b


def same_but_folder(path: Path, other: Path, old: Path, new: Path) -> bool:
    """The same columns, and the same metadata once `old`'s name is replaced by `new`'s."""
    a, b = pq.read_table(path), pq.read_table(other)
    meta = {k: v.replace(str(old).encode(), str(new).encode())
            for k, v in (a.schema.metadata or {}).items() if k != b"ARROW:schema"}
    columns = b.schema.remove_metadata()
    other_meta = {k: v for k, v in (b.schema.metadata or {}).items() if k != b"ARROW:schema"}
    return a.cast(columns).equals(b.cast(columns)) and meta == other_meta


def same_csv(path: Path, other: Path) -> bool:
    """The same table but for timing columns (a training history's `seconds`)."""
    a, b = pd.read_csv(path), pd.read_csv(other)
    return a.drop(columns=TIMINGS & set(a), errors="ignore").equals(
        b.drop(columns=TIMINGS & set(b), errors="ignore"))


def main(old: Path, new: Path) -> int:
    same = differ = 0
    for path in sorted(p for p in old.rglob("*") if p.is_file() and p.name != "times.txt"):
        rel = path.relative_to(old)
        other = new / rel
        if not other.exists():
            print("MISSING              ", rel)
            differ += 1
        elif path.read_bytes() == other.read_bytes():
            print("identical bytes      ", rel)
            same += 1
        elif path.suffix == ".parquet" and same_but_folder(path, other, old, new):
            print("identical but folder ", rel)
            same += 1
        elif path.suffix == ".json" and strip(json.loads(path.read_text())) == strip(
                json.loads(other.read_text())):
            print("identical but timings", rel)
            same += 1
        elif path.suffix == ".csv" and same_csv(path, other):
            print("identical but timings", rel)
            same += 1
        elif path.suffix == ".pt" and same_content(torch.load(path, weights_only=False),
                                                   torch.load(other, weights_only=False)):
            print("identical but timings", rel)
            same += 1
        else:
            print("DIFFERENT            ", rel)
            differ += 1
    extra = sorted(p.relative_to(new) for p in new.rglob("*")
                   if p.is_file() and not (old / p.relative_to(new)).exists())
    for rel in extra:
        print("ONLY NEW             ", rel)
    print(f"{same} same, {differ + len(extra)} different")
    return 1 if differ or extra else 0


if __name__ == "__main__":
    sys.exit(main(Path(sys.argv[1]), Path(sys.argv[2])))
