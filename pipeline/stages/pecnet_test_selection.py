"""Stage `pecnet_test_selection`: a labelled compat diagnostic of upstream PECNet's epoch selection
on the TEST set; never a headline number.

For every horizon of `pecnet_test_selection.horizons`, PECNet is retrained exactly as
`train_baseline@pecnet-<t_f>` trains it, in a temporary folder (the stage's checkpoints are never
touched), and after every epoch the test windows are scored (best of K, one seeded sampling) under
our protocol and PECNet's (`pipeline.studies.pecnet_test_selection`). The record: per epoch the
validation ADE and both protocols' test ADE / FDE; the epoch kept on validation
(`evaluate_baseline.epoch_selection`) and its test numbers; upstream's best test ADE and best test
FDE over epochs, each with its epoch; whether the retrain kept `train_baseline`'s epoch.
Params: `pecnet_test_selection`, `train_baseline` (seed, threads), `pecnet.<profile>`, `profile`,
`windows.n_past`, `evaluate_baseline.epoch_selection`, `runtime.device`.

    python -m pipeline.stages.pecnet_test_selection --tables data/horizon_windows/tf30.parquet \
        --training-facts metrics/baselines/train_pecnet_tf30.json \
        --out metrics/pecnet_test_selection.json
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

from pipeline.config.evaluate_baseline import EvaluateBaselineParams
from pipeline.config.loading import active_profile, load_profile, load_section, read_params
from pipeline.config.pecnet import PecnetConfig
from pipeline.config.pecnet_test_selection import PecnetTestSelectionParams
from pipeline.config.runtime import RuntimeParams
from pipeline.config.train_baseline import TrainBaselineParams
from pipeline.config.windows import WindowParams
from pipeline.studies.pecnet_test_selection import DiagnosticSettings, diagnose, summary_line
from pipeline.io import write_json


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--tables", type=Path, nargs="+", required=True,
                        help="window tables tf<t_f>.parquet, one per horizon of the params")
    parser.add_argument("--training-facts", type=Path, nargs="+", required=True,
                        help="train_pecnet_tf<t_f>.json of stage train_baseline, one per horizon")
    parser.add_argument("--out", type=Path, required=True, help="JSON written")
    args = parser.parse_args(argv)
    params = read_params()
    settings = DiagnosticSettings(
        active_profile(params),
        load_section(PecnetTestSelectionParams, "pecnet_test_selection", params),
        load_profile(PecnetConfig, "pecnet", params),
        load_section(TrainBaselineParams, "train_baseline", params),
        load_section(EvaluateBaselineParams, "evaluate_baseline", params).epoch_selection,
        load_section(WindowParams, "windows", params).n_past,
        load_section(RuntimeParams, "runtime", params))
    with tempfile.TemporaryDirectory(prefix="pecnet_test_selection_") as scratch:
        record = diagnose(settings, args.tables, args.training_facts, Path(scratch))
    for name, row in record["per_horizon"].items():
        kept, compat = row["validation_selected"], row["compat"]
        for protocol in record["protocols"]:
            print(f"pecnet_test_selection {name} {summary_line(kept, compat, protocol)}")
        print(f"pecnet_test_selection {name}: train_baseline's epoch reproduced: "
              f"{row['training_reproduced']['same']}")
    write_json(record, args.out)


if __name__ == "__main__":
    main()
