"""Old vs new outputs: every file byte-identical, or (JSON) identical but for timings."""
import hashlib, json, sys
from pathlib import Path
TIMINGS = {"eval_seconds", "eval_seconds_per_round", "train_seconds", "wall_seconds", "seconds_per_epoch"}
def strip(x):
    if isinstance(x, dict):
        return {k: strip(v) for k, v in x.items() if k not in TIMINGS}
    if isinstance(x, list):
        return [strip(v) for v in x]
    return x
old, new = Path("/work/runs/ident/old"), Path("/work/runs/ident/new")
same = differ = 0
for path in sorted(p for p in old.rglob("*") if p.is_file()):
    rel = path.relative_to(old); other = new / rel
    if not other.exists():
        print("MISSING", rel); differ += 1; continue
    if path.read_bytes() == other.read_bytes():
        print("identical bytes      ", rel); same += 1
    elif path.suffix == ".json" and strip(json.loads(path.read_text())) == strip(json.loads(other.read_text())):
        print("identical but timings", rel); same += 1
    else:
        print("DIFFERENT            ", rel); differ += 1
print(f"{same} same, {differ} different")
