"""Stage `rpecnet_rollouts`: a labelled diagnostic, never the headline. The t_f = 5 PECNet rolled
out in each way of `rpecnet_rollouts.variants` (`pipeline.runners.baselines.rpecnet.VARIANTS`),
scored on the validation windows of every horizon table of `rpecnet_rollouts.horizons`; the
variant whose FDE / ADE is the nearest to the paper's R-PECNet (`target_fde_over_ade`) is chosen
there and scored alone on the test windows (`pipeline.studies.rpecnet_rollouts`). Params:
`rpecnet_rollouts`, `evaluate_baseline.epoch_selection`, `windows.n_past`, `runtime.device`.

    python -m pipeline.stages.rpecnet_rollouts --horizon-windows data/horizon_windows \
        --checkpoint-dir checkpoints/pecnet_tf5 --out metrics/rpecnet_rollouts.json
"""

from __future__ import annotations

import argparse
from pathlib import Path

from pipeline.config.evaluate_baseline import EvaluateBaselineParams
from pipeline.config.loading import load_section, read_params
from pipeline.config.rpecnet_rollouts import RpecnetRolloutsParams
from pipeline.config.runtime import RuntimeParams
from pipeline.config.windows import WindowParams
from pipeline.studies.rpecnet_rollouts import rollouts_record
from pipeline.io import write_json


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--horizon-windows", type=Path, required=True,
                        help="folder of the horizon window tables tf<H>.parquet")
    parser.add_argument("--checkpoint-dir", type=Path, required=True, help="the t_f = 5 PECNet")
    parser.add_argument("--out", type=Path, required=True, help="metrics JSON written")
    parser.add_argument("--params", type=Path, default=Path("params.yaml"))
    args = parser.parse_args(argv)
    params = read_params(args.params)
    record = rollouts_record(
        args.horizon_windows, args.checkpoint_dir,
        load_section(RpecnetRolloutsParams, "rpecnet_rollouts", params),
        load_section(EvaluateBaselineParams, "evaluate_baseline", params).epoch_selection,
        load_section(WindowParams, "windows", params).n_past,
        load_section(RuntimeParams, "runtime", params))
    write_json(record, args.out)


if __name__ == "__main__":
    main()
