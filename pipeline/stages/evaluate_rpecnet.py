"""Stage `evaluate_rpecnet@<t_f>`: R-PECNet, the t_f = 5 PECNet rolled out on its own predictions to
horizon t_f, scored with the shared metric (as `evaluate_baseline --model rpecnet`; layout of
`metrics/baselines/<model>_tf<H>.json`), every round's predictions written. Params:
`evaluate_baseline`, `windows.n_past`, `runtime.device`.

    python -m pipeline.stages.evaluate_rpecnet --horizon 30 --table data/horizon_windows/tf30.parquet \
        --checkpoint-dir checkpoints/pecnet_tf5 --metrics metrics/baselines/rpecnet_tf30.json \
        --predictions data/predictions/long_term/tf30/rpecnet.parquet
"""

from __future__ import annotations

import argparse
from pathlib import Path

from pipeline.config.evaluate_baseline import EvaluateBaselineParams
from pipeline.config.loading import load_section, read_params
from pipeline.config.runtime import RuntimeParams
from pipeline.config.windows import WindowParams
from pipeline.model_list import RPECNET
from pipeline.runners.baseline_runs import score_to_file

MODEL = RPECNET


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--horizon", type=int, required=True, help="t_f in seconds")
    parser.add_argument("--table", type=Path, required=True, help="window table (parquet)")
    parser.add_argument("--checkpoint-dir", type=Path, required=True, help="the t_f = 5 PECNet")
    parser.add_argument("--metrics", type=Path, required=True, help="metrics JSON written")
    parser.add_argument("--predictions", type=Path, required=True,
                        help="every round's test predictions written (parquet)")
    args = parser.parse_args(argv)
    params = read_params()
    score_to_file(MODEL, args.table, args.horizon, args.checkpoint_dir, args.metrics,
                  args.predictions,
                  load_section(EvaluateBaselineParams, "evaluate_baseline", params),
                  load_section(WindowParams, "windows", params).n_past,
                  load_section(RuntimeParams, "runtime", params))


if __name__ == "__main__":
    main()
