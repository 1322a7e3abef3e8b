"""Stage `epoch_selection`: which epoch selection rule the long-term baselines are scored with,
judged on validation windows alone.

Every trained long-term baseline (S-GAN and PECNet, every horizon, the main training seed and the
extra ones) recorded its per-window validation ADE after each epoch. For each run the study halves
the validation windows at random, lets each rule (`raw`, `mean3`, ...) choose an epoch on one half
and scores it on the other (`pipeline.studies.epoch_selection`), then pools the runs: per rule the
mean ratio of its held-out ADE to `raw`'s, overall and per horizon, and the rule with the lowest
(`summary.recommended`), which `evaluate_baseline.epoch_selection` is set to. The test windows are
never read. Params: `epoch_selection_study`, `windows.horizons`, `train_baseline.seed`,
`baseline_seeds.extra`.

    python -m pipeline.stages.epoch_selection --checkpoints checkpoints --out metrics/epoch_selection.json
"""

from __future__ import annotations

import argparse
from pathlib import Path

from pipeline.config.baseline_seeds import BaselineSeedsParams
from pipeline.config.epoch_selection_study import EpochSelectionStudyParams
from pipeline.config.loading import load_section, read_params
from pipeline.config.train_baseline import TrainBaselineParams
from pipeline.config.windows import WindowParams
from pipeline.io import write_json
from pipeline.studies.epoch_selection import epoch_selection_study, long_term_runs


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--checkpoints", type=Path, required=True,
                        help="folder of <model>_tf<H>/ (main seed) and seeds/<model>_tf<H>_seed<S>/")
    parser.add_argument("--out", type=Path, required=True, help="JSON written")
    args = parser.parse_args(argv)
    params = read_params()
    study = load_section(EpochSelectionStudyParams, "epoch_selection_study", params)
    horizons = load_section(WindowParams, "windows", params).horizons
    main_seed = load_section(TrainBaselineParams, "train_baseline", params).seed
    extra = load_section(BaselineSeedsParams, "baseline_seeds", params).extra
    runs = long_term_runs(args.checkpoints, horizons, main_seed, extra)
    record = epoch_selection_study(runs, study.n_splits, study.seed)
    summary = record["summary"]
    for rule, row in summary["overall"].items():
        print(f"epoch_selection: {rule:6s} held-out val ADE / raw's {row['mean_ratio_to_raw']:.4f} "
              f"(better on {row['runs_better_than_raw']}, worse on {row['runs_worse_than_raw']} "
              f"of {row['runs']} runs)")
    print(f"epoch_selection: recommended {summary['recommended']}")
    write_json(record, args.out)


if __name__ == "__main__":
    main()
