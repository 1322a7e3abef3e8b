"""Stage `animations`: Y-net's predictions unfolding step by step, one animated WebP per stored
qualitative window of each benchmark, for the report's "Predictions, step by step".

Each `--qualitative <label>=<path>` names a benchmark and the `.npz` its Y-net evaluation stored
(format: `pipeline.report.animation`). Writes into `--out` the files `<label>_<i>.webp` and
`index.json`: {"benchmarks": [{"benchmark", "title", "source", "status": "shown" | "missing",
"reason" (missing only), "windows": [{"file", "scene_id", "bytes", "frames", "n_past", "n_future",
"k"}]}]}, in the order given. A file that does not exist (a benchmark whose evaluation has not run)
is recorded as missing; a malformed one stops the stage with the file and the key. Params: none.

A stage of its own, not a step of `report`: about 0.5 s a window (1.5 s for the three long-term
windows, several more once the short-term benchmarks store theirs), redone only when an `.npz`
changes rather than on every metrics change that re-renders the page (5.9 s).

    python -m pipeline.stages.animations --qualitative long_term=data/ynet_predictions/qualitative.npz \
        --out reports/figures/animations
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from pipeline.io import atomic_dir, exit_on_bad_intermediate
from pipeline.report.animation import LABEL, render_benchmark


def labelled_path(text: str) -> tuple[str, Path]:
    """'<label>=<path>' -> (label, path); the label names files, so [a-z0-9_]+ only."""
    label, sep, path = text.partition("=")
    if not sep or not path or not LABEL.fullmatch(label):
        raise argparse.ArgumentTypeError(f"expected <label>=<path> with a label of [a-z0-9_], got {text!r}")
    return label, Path(path)


@exit_on_bad_intermediate
def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--qualitative", type=labelled_path, action="append", required=True,
                        metavar="LABEL=PATH", help="a benchmark's qualitative .npz (repeat per benchmark)")
    parser.add_argument("--out", type=Path, required=True, help="folder of the animations and index.json")
    args = parser.parse_args(argv)
    labels = [label for label, _ in args.qualitative]
    if len(set(labels)) != len(labels):
        parser.error(f"each label once: {labels}")
    rendered = [render_benchmark(label, path) for label, path in args.qualitative]
    with atomic_dir(args.out, mode=0o755) as staged:
        for benchmark in rendered:
            for name, data in benchmark.files.items():
                (staged / name).write_bytes(data)
        index = {"benchmarks": [benchmark.entry for benchmark in rendered]}
        (staged / "index.json").write_text(json.dumps(index, indent=2) + "\n")
    for benchmark in rendered:
        entry = benchmark.entry
        sizes = ", ".join(f"{w['file']} {w['bytes'] / 1e3:.0f} kB" for w in entry["windows"])
        print(f"{entry['benchmark']}: {sizes or entry.get('reason')}")


if __name__ == "__main__":
    main()
