"""Stage `evaluate_rpecnet_seed@<t_f>-<seed>`: R-PECNet from the t_f = 5 PECNet of an extra
training seed (`train_baseline_seed@pecnet-5-<seed>`), scored exactly as `evaluate_rpecnet`
scores the main one (same split, K, rounds and round seeds), with `training_seed` in the record and
no stored predictions. Params: `evaluate_baseline`, `windows.n_past`, `runtime.device`.

    python -m pipeline.stages.evaluate_rpecnet_seed --horizon 30 --table data/horizon_windows/tf30.parquet \
        --checkpoint-dir checkpoints/seeds/pecnet_tf5_seed1 --metrics metrics/baselines/seeds/rpecnet_tf30_seed1.json
"""

from __future__ import annotations

import argparse
from pathlib import Path

from pipeline.config.evaluate_baseline import EvaluateBaselineParams
from pipeline.config.loading import load_section, read_params
from pipeline.config.runtime import RuntimeParams
from pipeline.config.windows import WindowParams
from pipeline.model_list import RPECNET
from pipeline.runners.baseline_runs import score_to_file, training_seed

MODEL = RPECNET


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--horizon", type=int, required=True, help="t_f in seconds")
    parser.add_argument("--table", type=Path, required=True, help="window table (parquet)")
    parser.add_argument("--checkpoint-dir", type=Path, required=True, help="the extra seed's t_f = 5 PECNet")
    parser.add_argument("--metrics", type=Path, required=True, help="metrics JSON written")
    args = parser.parse_args(argv)
    params = read_params()
    score_to_file(MODEL, args.table, args.horizon, args.checkpoint_dir, args.metrics, None,
                  load_section(EvaluateBaselineParams, "evaluate_baseline", params),
                  load_section(WindowParams, "windows", params).n_past,
                  load_section(RuntimeParams, "runtime", params),
                  {"training_seed": training_seed(args.checkpoint_dir)})


if __name__ == "__main__":
    main()
