"""What DVC's lock updates cost the driver, with and without `lock_parsed_once`
(`tools/parallel_repro.py`): on a copy of the real dvc.lock, each of the first N stages' entries
replaced (new hashes and sizes) in one `modify_yaml` each, as DVC records a finished stage; CPU
seconds of each sequence, and whether the two files end byte-identical.

    python -m docs.experiments.dask_runner_lock_updates [--lock dvc.lock] [--updates 12]
"""

import argparse
import contextlib
import copy
import shutil
import tempfile
import time
from pathlib import Path


def update_sequence(lock: Path, updates: int, remembered: bool) -> float:
    """CPU seconds of `updates` stage-entry updates of `lock` (changed in place)."""
    from dvc.utils.serialize import modify_yaml, parse_yaml
    from tools.parallel_repro import lock_parsed_once

    original = parse_yaml(lock.read_text(), str(lock))["stages"]
    started = time.process_time()
    with lock_parsed_once() if remembered else contextlib.nullcontext():
        for step, name in enumerate(list(original)[:updates]):
            entry = copy.deepcopy(original[name])
            for out in entry.get("outs", []):
                out["md5"], out["size"] = f"{step:032x}", out.get("size", 0) + 1
            with modify_yaml(lock) as data:
                data["stages"].update({name: entry})
    return time.process_time() - started


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--lock", type=Path, default=Path("dvc.lock"))
    parser.add_argument("--updates", type=int, default=12)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as scratch:
        copies = {}
        for remembered in (False, True):
            copies[remembered] = Path(scratch) / f"remembered-{remembered}.lock"
            shutil.copyfile(args.lock, copies[remembered])
            seconds = update_sequence(copies[remembered], args.updates, remembered)
            print(f"lock_parsed_once {'on ' if remembered else 'off'}: {args.updates} updates in "
                  f"{seconds:.1f} CPU s ({seconds / args.updates:.2f} s each)", flush=True)
        same = copies[False].read_bytes() == copies[True].read_bytes()
        print(f"the two locks byte-identical: {same} ({copies[True].stat().st_size} bytes)")


if __name__ == "__main__":
    main()
